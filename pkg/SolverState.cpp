// Saving and restoring a solver's state (Solver::saveState / loadState): the format is a header
// (format name, version, dimension, kernel) and named sections, each checked on reading.
#include <sstream>
#include <type_traits>

#include "Archive.hpp"
#include "Laws.hpp"
#include "Solver.hpp"

namespace emp {

namespace {
const char* kFormat = "EigenMPM solver state";
constexpr std::uint32_t kVersion = 10;  // 2: transfer, stress update, energy diagnostics; 3: contact work, crack-face contact;
                                       // 4: bodies in one grid (point body ids, their friction); 5: a rank's part
                                       // of a distributed run (its flag, point ids, the ranks' strips); 6: the
                                       // points' reference positions of a run distributed at set-up; 7: the
                                       // scheduler's columns, and a distributed run's columns of ranks; 8: a 2D
                                       // point's strain and stress as symmetric tensors (three numbers), and
                                       // no mass array (a point's mass is rho V), and the elastic energy
                                       // density c psi+ + psi- in place of psi+ and psi-; 9: no strain
                                       // array with the co-rotational update (its strain follows from F); 10:
                                       // no stress array (it follows from the strain or F and the damage)

/// A point array as saved; before version 8 a 2D strain or stress was a full 2 x 2 matrix.
template <class T> void readPointArray(ArchiveReader& r, int version, std::vector<T>& a)
{
    if constexpr (std::is_same<T, Sym2>::value) {
        if (version < 8) {
            std::vector<Mat<2>> full;
            r.array(full);
            a.assign(full.begin(), full.end());  // (their symmetric parts: the tensors themselves)
            return;
        }
    }
    r.array(a);
}
}  // namespace

StateHeader readStateHeader(std::istream& is)
{
    ArchiveReader r(is);
    const std::string format = r.string();
    if (format != kFormat) r.fail("no EigenMPM solver state (it starts with '" + format.substr(0, 40) + "')");
    const auto version = r.value<std::uint32_t>();
    if (version < 1 || version > kVersion)
        r.fail("format version " + std::to_string(version) + "; this EigenMPM reads versions 1 to " +
               std::to_string(kVersion));
    StateHeader h;
    h.version = static_cast<int>(version);
    h.dim = r.value<std::int32_t>();
    h.kernel = r.string();
    return h;
}

template <int D, class K> void Solver<D, K>::saveState(std::ostream& os) const
{
    for (std::size_t i = 0; i < conditions_.size(); ++i)
        if (!std::dynamic_pointer_cast<VelocityCondition<D>>(conditions_[i]))
            throw SimulationError("EigenMPM: cannot save the state: grid condition " + std::to_string(i) +
                                  " is not a VelocityCondition and has no saved form");
    if (dist_ && !dist_->partitioned())
        throw SimulationError("EigenMPM: cannot save the state of a run distributed at set-up before its first step "
                              "(no rank holds the scene then); save after a step, or rebuild the scene");
    ArchiveWriter w(os);
    w.string(kFormat);
    w.value(kVersion);
    w.value<std::int32_t>(D);
    w.string(K::name);

    w.string("settings");
    w.value(settings_.h);
    w.value(settings_.ppc);
    w.value(settings_.gravity);
    w.value(settings_.massCutoff);
    w.value(settings_.padding);
    w.string(name(settings_.transfer));
    w.string(name(settings_.stressUpdate));
    w.value(settings_.columnCells);

    w.string("solver");
    w.value(haveDomain_);
    w.value(domainLo_);
    w.value(domainHi_);
    w.value(initialized_);
    w.value(massCutoffAbs_);
    w.value(time_);
    w.value(maxSpeed_);
    w.value(steps_);
    w.value(kineticAtStep_);
    w.value(tractionWork_);
    w.value(gravityWork_);
    w.value(contactWork_);
    w.value(crackContact_ != nullptr);
    w.value(crackContact_ ? crackContact_->friction : 0.0);
    w.value(points_.bodies);
    w.value(bodyContact_.friction);
    w.value(points_.distributed);
    w.value(points_.referenced);
    w.value(grid_.origin);
    w.value(grid_.n);

    w.string("materials");
    w.array(materials_);
    for (const auto& m : materials_) w.string(lawNames()[m.law]);

    w.string("points");
    const_cast<MaterialPoints<D>&>(points_).forEachArray([&](const char* name, const auto& a) {
        w.string(name);
        w.array(a);
    });

    w.string("conditions");
    w.value<std::uint64_t>(velocityConditions_.size());
    for (const auto& c : velocityConditions_) {
        w.array(c->nodes);
        w.array(c->points);
        w.value(c->mask);
        w.value(c->velocity);
        w.value(c->rampTime);
        w.value(c->reaction);
        w.value(c->work);
    }

    w.string("tractions");
    w.value<std::uint64_t>(tractions_.size());
    for (const auto& t : tractions_) {
        w.array(t.points);
        w.value(t.traction);
        w.value(t.rampTime);
        w.value(t.layer);
    }

    w.string("cracks");
    w.value<std::uint64_t>(phantom_.numCracks());
    for (std::size_t c = 0; c < phantom_.numCracks(); ++c) w.array(phantom_.vertices(static_cast<int>(c)));

    w.string("erosion");
    w.value(erosion_ != nullptr);
    if (erosion_) {
        w.value(erosion_->settings());
        erosion_->saveState(w);
    }
    // A distributed run's archive is one rank's part: which rank, of how many, and the strips
    // of every rank, so that the same number of ranks resumes it (distribute()).
    w.string("distribution");
    w.value(dist_ ? dist_->rank() : 0);
    w.value(dist_ ? dist_->size() : 1);
    w.array(dist_ ? dist_->firstStrips() : std::vector<int>{});
    w.array(dist_ ? dist_->firstColumns() : std::vector<int>{});  // (version 7: the columns of ranks)
    w.string("end");
    if (!os) throw SimulationError("EigenMPM: writing the solver state failed");
}

template <int D, class K> std::shared_ptr<Solver<D, K>> Solver<D, K>::loadState(std::istream& is)
{
    const StateHeader h = readStateHeader(is);
    ArchiveReader r(is);
    if (h.dim != D || h.kernel != K::name)
        r.fail("a " + std::to_string(h.dim) + "D " + h.kernel + " solver, read as a " + std::to_string(D) + "D " +
               K::name + " one");
    r.expect("settings");
    SolverSettings st;
    st.h = r.value<double>();
    st.ppc = r.value<int>();
    st.gravity = r.value<Eigen::Vector3d>();
    st.massCutoff = r.value<double>();
    st.padding = r.value<int>();
    // Version 1 (before the options) had the paper's FLIP transfer and small-strain update.
    st.transfer = Transfer::flip;
    st.stressUpdate = StressUpdate::smallStrain;
    if (h.version >= 2) {
        const std::string transfer = r.string(), update = r.string();
        st.transfer = transferOf(transfer);
        st.stressUpdate = stressUpdateOf(update);
        if (st.transfer == Transfer::unset || st.stressUpdate == StressUpdate::unset)
            r.fail("the transfer '" + transfer + "' or stress update '" + update + "', which this EigenMPM does not have");
    }
    if (h.version >= 7) st.columnCells = r.value<int>();
    auto s = std::make_shared<Solver<D, K>>(st);

    r.expect("solver");
    s->haveDomain_ = r.value<bool>();
    s->domainLo_ = r.value<Vec<D>>();
    s->domainHi_ = r.value<Vec<D>>();
    const bool initialized = r.value<bool>();
    s->massCutoffAbs_ = r.value<double>();
    s->time_ = r.value<double>();
    s->maxSpeed_ = r.value<double>();
    s->steps_ = r.value<std::int64_t>();
    if (h.version >= 2) {
        s->kineticAtStep_ = r.value<double>();
        s->tractionWork_ = r.value<double>();
        s->gravityWork_ = r.value<double>();
    }
    if (h.version >= 3) {
        s->contactWork_ = r.value<double>();
        const bool crackContact = r.value<bool>();
        const double friction = r.value<double>();
        if (crackContact) s->setCrackContact(true, friction);
    }
    if (h.version >= 4) {
        s->points_.bodies = r.value<bool>();
        s->bodyContact_.friction = r.value<double>();
    }
    if (h.version >= 5) s->points_.distributed = r.value<bool>();
    if (h.version >= 6) s->points_.referenced = r.value<bool>();
    const auto origin = r.value<Vec<D>>();
    const auto n = r.value<std::array<int, D>>();
    if (initialized) {
        s->grid_.resize(origin, st.h, n);
        s->initialized_ = true;
    }

    r.expect("materials");
    r.array(s->materials_);
    for (const auto& m : s->materials_) s->points_.density.push_back(m.rho);
    for (auto& m : s->materials_) {
        const std::string law = r.string();
        m.law = lawIndex(law);
        if (m.law < 0) r.fail("a material with the law '" + law + "', which this EigenMPM does not have");
    }

    r.expect("points");
    std::vector<double> psiPlus, psiMinus;
    s->points_.forEachArray([&](const char* name, auto& a) {
        if (h.version < 2 && s->points_.expectedLength(name) == 0) return;  // (optional arrays came with 2)
        if (h.version < 4 && std::string(name) == "body") return;          // (and the bodies with 4)
        if (h.version < 5 && std::string(name) == "globalId") return;      // (and a rank's part with 5)
        if (h.version < 6 && std::string(name) == "reference") return;     // (and its reference positions with 6)
        if (h.version < 8 && std::string(name) == "volume") {  // (a mass array until 8: rho V, now computed)
            r.expect("mass");
            std::vector<double> mass;
            r.array(mass);
        }
        if (h.version < 10 && std::string(name) == "energy") {  // (the stress until 10, before the energy)
            r.expect("stress");
            std::vector<PointTensor<D>> stored;
            readPointArray(r, h.version, stored);
            if (stored.size() != s->points_.size()) r.fail("a point array 'stress' of another length");
        }
        if (h.version < 8 && std::string(name) == "energy") {  // (psi+ and psi- until 8: c psi+ + psi- now)
            r.expect("psiPlus");
            r.array(psiPlus);
            r.expect("psiMinus");
            r.array(psiMinus);
            return;
        }
        r.expect(name);
        if (h.version < 9 && std::string(name) == "strain" && s->points_.deformation) {  // (the co-rotated
            std::remove_reference_t<decltype(a)> stored;                                  // strain until 9)
            readPointArray(r, h.version, stored);
            if (stored.size() != s->points_.size()) r.fail("a point array 'strain' of another length");
            return;
        }
        readPointArray(r, h.version, a);
        if (a.size() != s->points_.expectedLength(name))
            r.fail(std::string("a point array '") + name + "' of another length");
    });
    if (h.version < 8) {
        auto& P = s->points_;
        if (psiPlus.size() != P.size() || psiMinus.size() != P.size()) r.fail("psi arrays of another length");
        P.energy.resize(P.size());
        for (std::size_t p = 0; p < P.size(); ++p) P.energy[p] = P.damage[p] * psiPlus[p] + psiMinus[p];
    }

    r.expect("conditions");
    const auto nc = r.value<std::uint64_t>();
    for (std::uint64_t i = 0; i < nc; ++i) {
        auto c = std::make_shared<VelocityCondition<D>>();
        r.array(c->nodes);
        r.array(c->points);
        c->mask = r.value<unsigned>();
        c->velocity = r.value<Eigen::Vector3d>();
        c->rampTime = r.value<double>();
        c->reaction = r.value<Eigen::Vector3d>();
        if (h.version >= 2) c->work = r.value<double>();
        s->velocityConditions_.push_back(c);
        s->conditions_.push_back(c);
    }

    r.expect("tractions");
    const auto nt = r.value<std::uint64_t>();
    for (std::uint64_t i = 0; i < nt; ++i) {
        TractionCondition t;
        r.array(t.points);
        t.traction = r.value<Eigen::Vector3d>();
        t.rampTime = r.value<double>();
        t.layer = r.value<double>();
        s->tractions_.push_back(std::move(t));
    }

    r.expect("cracks");
    const auto ncr = r.value<std::uint64_t>();
    for (std::uint64_t c = 0; c < ncr; ++c) {
        std::vector<Vec<D>> v;
        r.array(v);
        s->phantom_.restoreCrack(v);
    }
    // The marked nodes and twins (numTwins) for the cracks' restored position: those the next step
    // marks first thing (a diagnostic only: every step marks afresh, so the continuation is the same).
    if (s->initialized_ && !s->phantom_.empty()) s->markCrackedNodes();

    r.expect("erosion");
    if (r.value<bool>()) {
        auto e = std::make_shared<EigenErosion<D>>(r.value<ErosionSettings>());
        e->loadState(r);
        s->erosion_ = e;
    }
    if (h.version >= 5) {
        r.expect("distribution");
        s->resumeRank_ = r.value<int>();
        s->resumeRanks_ = r.value<int>();
        r.array(s->resumeStrips_);
        if (h.version >= 7) r.array(s->resumeColumns_);
        if (s->points_.distributed != (s->resumeRanks_ > 1 || !s->resumeStrips_.empty()))
            r.fail("a distribution section that does not match its points");
    }
    r.expect("end");
    return s;
}

#define EMP_INSTANTIATE(D, K)                                                      \
    template void Solver<D, K>::saveState(std::ostream&) const;                    \
    template std::shared_ptr<Solver<D, K>> Solver<D, K>::loadState(std::istream&);
EMP_SOLVER_CONFIGURATIONS(EMP_INSTANTIATE)
#undef EMP_INSTANTIATE

}  // namespace emp
