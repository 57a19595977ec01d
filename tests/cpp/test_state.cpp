// Saving and restoring a solver (Solver::saveState / loadState): continuing a restored solver
// gives bitwise the results of the one that was saved, in every configuration, with a crack
// and while eroding, on 1 and 2 threads; archives that cannot be restored are refused loudly.
#include <cstring>
#include <sstream>

#include "test_helpers.hpp"

namespace {

using emp::Vec;

template <class C> struct StateTest : ::testing::Test {};
TYPED_TEST_SUITE(StateTest, emptest::AllSolvers);

/// A block with a random velocity field, a velocity condition, a ramped traction, an interior
/// crack and an erosion stage whose Gc some points reach within the run.
template <int D, class K>
std::shared_ptr<emp::Solver<D, K>> scene(unsigned seed, int columnCells = 0,
                                        emp::StressUpdate update = emp::StressUpdate::smallStrain)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    auto st = emptest::typicalSettings(0.01, 2);
    st.columnCells = columnCells;
    st.stressUpdate = update;
    if (update == emp::StressUpdate::corotational && K::affineTransfer) st.transfer = emp::Transfer::apic;
    st.gravity = Eigen::Vector3d(0.0, -9.81, 0.0);
    auto s = std::make_shared<emp::Solver<D, K>>(st);
    const int mat = s->addMaterial(1e7, 0.25, 1000, D == 2, emp::lawIndex("spectral"));
    const int soft = s->addMaterial(5e6, 0.2, 900, false, emp::lawIndex("volumetric"));
    const double c = s->materials()[mat].waveSpeed();
    std::array<int, D> lo, hi;
    lo.fill(2);
    hi.fill(D == 2 ? 9 : 6);
    const auto ids = emptest::addBlock<D>(*s, lo, hi, mat, [&](const Vec<D>& x) {
        Vec<D> v;
        for (int d = 0; d < D; ++d) v[d] = 5e-3 * c * (std::sin(90.0 * x[(d + 1) % D]) + 0.3 * u(rng));
        return v;
    });
    for (std::size_t k = 0; k < ids.size(); k += 3) s->points().material[ids[k]] = soft;
    std::vector<int> bottom, top;
    for (int p : ids) {
        if (s->points().x[p][1] < 0.0225) bottom.push_back(p);
        if (s->points().x[p][1] > (hi[1] - 0.25) * 0.01) top.push_back(p);
    }
    s->addVelocityCondition({}, bottom, 2u, Eigen::Vector3d::Zero(), 0.0);
    s->addTraction(top, Eigen::Vector3d(0, 4e4, 0), 1e-4, 0.01);
    if (D == 2)
        s->addCrack({Eigen::Vector3d(0.031, 0.052, 0), Eigen::Vector3d(0.062, 0.049, 0)});
    else
        s->addCrack({Eigen::Vector3d(0.031, 0.04, 0.031), Eigen::Vector3d(0.052, 0.04, 0.031),
                     Eigen::Vector3d(0.052, 0.041, 0.052), Eigen::Vector3d(0.031, 0.041, 0.052)});
    s->setErosion(std::make_shared<emp::EigenErosion<D>>(emp::ErosionSettings{0.02, 2.0, 0.011}));
    return s;
}

template <class Sv> void expectSame(const Sv& a, const Sv& b)
{
    const auto &P = a.points(), &Q = b.points();
    ASSERT_EQ(P.size(), Q.size());
    for (std::size_t p = 0; p < P.size(); ++p) {
        ASSERT_EQ(P.x[p], Q.x[p]) << "point " << p;
        ASSERT_EQ(P.v[p], Q.v[p]) << "point " << p;
        ASSERT_EQ(a.stressOf(p), b.stressOf(p)) << "point " << p;
        ASSERT_EQ(P.history[p], Q.history[p]) << "point " << p;
        ASSERT_EQ(P.damage[p], Q.damage[p]) << "point " << p;
    }
    EXPECT_EQ(a.time(), b.time());
    EXPECT_EQ(a.steps(), b.steps());
    EXPECT_EQ(a.reaction(0), b.reaction(0));
    EXPECT_EQ(a.erosion()->dissipatedEnergy(), b.erosion()->dissipatedEnergy());
    EXPECT_EQ(a.erosion()->erodedCount(), b.erosion()->erodedCount());
    EXPECT_EQ(a.phantomNodes().vertices(0), b.phantomNodes().vertices(0));
    EXPECT_EQ(a.criticalTimeStep(), b.criticalTimeStep());
}

/// Each point's energy density is its law's c psi+ + psi- at its strain, points eroded in the
/// last step included (erosion rewrites theirs): what psiPlus()/psiMinus() recompute. With APIC
/// and the co-rotational update, at the strain of F as the step's stress pass had it (`before`:
/// G2P has moved F since; Solver::deformationInG2P).
template <class Sv> void expectEnergyOfTheLaw(const Sv& a, const std::vector<emp::Mat<Sv::dim>>* before = nullptr)
{
    constexpr int D = Sv::dim;
    const auto& P = a.points();
    for (std::size_t p = 0; p < P.size(); ++p) {
        emp::Mat<D> eps = P.strainOf(p);
        if (before) {
            emp::Mat<D> R, U;
            ASSERT_TRUE(emp::polarDecomposition((*before)[p], R, U)) << "point " << p;
            eps = U - emp::Mat<D>::Identity();
        }
        const auto r = emp::lawResponse<D>(eps, a.materials()[P.material[p]]);
        ASSERT_EQ(emptest::bits(P.energy[p]), emptest::bits(P.damage[p] * r.psiPlus + r.psiMinus)) << "point " << p;
    }
}

TYPED_TEST(StateTest, RestoredSolverContinuesBitwise)
{
    constexpr int D = TypeParam::D;
    using K = typename TypeParam::K;
    using Sv = emp::Solver<D, K>;
    for (int columns : {0, 2})  // (the scheduler's columns are saved: Scheduler.hpp)
    for (int threads : {1, 2}) {
        auto a = scene<D, K>(3, columns);
        const double dt = 0.5 * a->criticalTimeStep();
        int erodingSteps = 0;
        for (int k = 0; k < 15; ++k) {
            a->step(dt, threads);
            if (!a->erosion()->lastEroded().empty()) {
                ++erodingSteps;
                expectEnergyOfTheLaw(*a);
            }
        }
        std::stringstream archive;
        a->saveState(archive);
        auto b = Sv::loadState(archive);
        EXPECT_EQ(b->settings().columnCells, columns);
        expectSame(*a, *b);
        // The restored solver counts the twins of its crack's position, which the next step marks.
        const int twinsAfterLoad = b->phantomNodes().numTwins();
        EXPECT_GT(twinsAfterLoad, 0);
        a->step(dt, threads);
        b->step(dt, 3 - threads);
        EXPECT_EQ(twinsAfterLoad, a->phantomNodes().numTwins());
        for (int k = 0; k < 24; ++k) {
            a->step(dt, threads);
            b->step(dt, 3 - threads);  // and on the other thread count
            if (!a->erosion()->lastEroded().empty()) {
                ++erodingSteps;
                expectEnergyOfTheLaw(*a);
            }
        }
        expectSame(*a, *b);
        EXPECT_GT(a->erosion()->erodedCount(), 0u) << "the run should erode";
        EXPECT_GT(erodingSteps, 0);
        EXPECT_GT(a->phantomNodes().numTwins(), 0);
    }
}

TYPED_TEST(StateTest, ArchivesThatCannotBeRestoredAreRefused)
{
    constexpr int D = TypeParam::D;
    using K = typename TypeParam::K;
    using Sv = emp::Solver<D, K>;
    auto a = scene<D, K>(4);
    a->step(0.5 * a->criticalTimeStep(), 1);
    std::stringstream archive;
    a->saveState(archive);
    const std::string bytes = archive.str();
    // Truncated anywhere.
    for (std::size_t cut : {std::size_t(3), bytes.size() / 2, bytes.size() - 1}) {
        std::stringstream s(bytes.substr(0, cut));
        const std::string m = emptest::messageOf<emp::SimulationError>([&] { Sv::loadState(s); });
        EXPECT_TRUE(emptest::contains(m, "cannot be restored")) << m;
    }
    // Another version.
    std::string other = bytes;
    const std::size_t versionAt = 8 + std::string("EigenMPM solver state").size();
    const int version = static_cast<unsigned char>(other[versionAt]);  // this build's (little-endian)
    other[versionAt] = static_cast<char>(other[versionAt] + 1);
    std::stringstream sv(other);
    const std::string mv = emptest::messageOf<emp::SimulationError>([&] { Sv::loadState(sv); });
    EXPECT_TRUE(emptest::contains(mv, "format version " + std::to_string(version + 1))) << mv;
    EXPECT_TRUE(emptest::contains(mv, "reads versions 1 to " + std::to_string(version))) << mv;
    // Not a state at all.
    std::stringstream junk(std::string(200, 'x'));
    EXPECT_THROW(Sv::loadState(junk), emp::SimulationError);
    // Another configuration.
    std::stringstream s2(bytes);
    if (D == 2) {
        const std::string m = emptest::messageOf<emp::SimulationError>([&] { emp::Solver<3, K>::loadState(s2); });
        EXPECT_TRUE(emptest::contains(m, "read as a 3D")) << m;
    } else {
        const std::string m = emptest::messageOf<emp::SimulationError>([&] { emp::Solver<2, K>::loadState(s2); });
        EXPECT_TRUE(emptest::contains(m, "read as a 2D")) << m;
    }
}

/// A name as an archive writes it: a 64-bit length, then the characters.
std::string tagOf(const std::string& name)
{
    std::string tag(8, '\0');
    const std::uint64_t n = name.size();
    std::memcpy(&tag[0], &n, 8);
    return tag + name;
}

/// The bytes of the named point array `name` in a saved state: the offset of its element count
/// (after the tag, a 64-bit length and the name's characters).
std::size_t arrayAt(const std::string& bytes, const std::string& name)
{
    const std::string tag = tagOf(name);
    const std::size_t at = bytes.find(tag);
    EXPECT_NE(at, std::string::npos) << name;
    return at + tag.size();
}

/// An array as an archive writes it: a 64-bit count, then the values.
std::string arrayOf(const std::vector<double>& a)
{
    std::string out(8, '\0');
    const std::uint64_t n = a.size();
    std::memcpy(&out[0], &n, 8);
    return out.append(reinterpret_cast<const char*>(a.data()), 8 * n);
}

/// The state as a version before 10 wrote it: the points' stresses (as stored until then: three
/// numbers a 2D point, the nine of a 3D one) before their energies; `version` in the header.
template <class Sv> std::string withStresses(std::string bytes, const Sv& s, std::uint32_t version)
{
    const std::size_t versionAt = 8 + std::string("EigenMPM solver state").size();
    std::memcpy(&bytes[versionAt], &version, 4);
    std::vector<double> values;
    for (std::size_t p = 0; p < s.points().size(); ++p) {
        const emp::PointTensor<Sv::dim> t(s.stressOf(p));
        const double* d = reinterpret_cast<const double*>(&t);
        values.insert(values.end(), d, d + sizeof t / sizeof(double));
    }
    std::string array = arrayOf(values);
    const std::uint64_t n = s.points().size();
    std::memcpy(&array[0], &n, 8);
    bytes.insert(arrayAt(bytes, "energy") - tagOf("energy").size(), tagOf("stress") + array);
    return bytes;
}

/// The state as version 7 wrote it: a 2D point's strain and stress as full 2 x 2 matrices, the
/// points' masses saved (before their volumes), and psi+ and psi- in place of the energy density.
std::string asVersion7(std::string bytes, const emp::Solver<2, emp::GimpKernel>& s)
{
    bytes = withStresses(bytes, s, 7);
    const auto& P = s.points();
    std::vector<double> psiPlus, psiMinus;
    for (std::size_t p = 0; p < P.size(); ++p) {
        const auto r = emp::lawResponse<2>(emp::full(P.strain[p]), s.materials()[P.material[p]]);
        psiPlus.push_back(r.psiPlus);
        psiMinus.push_back(r.psiMinus);
    }
    for (const char* name : {"strain", "stress"}) {
        const std::size_t at = arrayAt(bytes, name);
        std::uint64_t n;
        std::memcpy(&n, &bytes[at], 8);
        std::string full;
        for (std::uint64_t p = 0; p < n; ++p) {
            emp::Sym2 t;
            std::memcpy(&t, &bytes[at + 8 + 24 * p], 24);
            const emp::Mat<2> m = t.mat();
            full.append(reinterpret_cast<const char*>(m.data()), 32);
        }
        bytes.replace(at + 8, 24 * n, full);
    }
    bytes.insert(arrayAt(bytes, "volume") - tagOf("volume").size(), tagOf("mass") + arrayOf(P.masses()));
    const std::size_t energy = arrayAt(bytes, "energy") - tagOf("energy").size();
    bytes.replace(energy, tagOf("energy").size() + 8 + 8 * P.size(),
                  tagOf("psiPlus") + arrayOf(psiPlus) + tagOf("psiMinus") + arrayOf(psiMinus));
    return bytes;
}

TEST(StateTest2D, AStateOfVersion7IsRestoredWithItsFullTensors)
{
    // Version 8 stores a 2D point's strain and stress as three numbers (PointTensor.hpp), no
    // masses (rho V) and c psi+ + psi- instead of psi+ and psi-; a state saved before reads its
    // full matrices, whose symmetric parts are the tensors, passes over its masses and sums its
    // energy densities.
    using Sv = emp::Solver<2, emp::GimpKernel>;
    auto a = scene<2, emp::GimpKernel>(5);
    const double dt = 0.5 * a->criticalTimeStep();
    for (int k = 0; k < 20; ++k) a->step(dt, 1);
    std::stringstream archive;
    a->saveState(archive);
    std::stringstream old(asVersion7(archive.str(), *a));
    EXPECT_NE(old.str().size(), archive.str().size());
    auto b = Sv::loadState(old);
    for (std::size_t p = 0; p < a->points().size(); ++p)
        ASSERT_EQ(emp::full(a->points().strain[p]), emp::full(b->points().strain[p])) << "point " << p;
    EXPECT_EQ(a->points().energy, b->points().energy);
    EXPECT_EQ(a->elasticEnergy(), b->elasticEnergy());
    expectSame(*a, *b);
    for (int k = 0; k < 10; ++k) {
        a->step(dt, 1);
        b->step(dt, 2);
    }
    expectSame(*a, *b);
}

/// The element count of the named point array in a saved state.
std::uint64_t countOf(const std::string& bytes, const std::string& name)
{
    std::uint64_t n;
    std::memcpy(&n, &bytes[arrayAt(bytes, name)], 8);
    return n;
}

TYPED_TEST(StateTest, CoRotationalStateSavesNoStrainAndContinuesBitwise)
{
    // The co-rotational update stores F and derives the co-rotated strain from it
    // (MaterialPoints::strainOf): the state has an empty strain array, and a restored solver
    // continues bitwise, its eroded points' energies those of the derived strain.
    constexpr int D = TypeParam::D;
    using K = typename TypeParam::K;
    using Sv = emp::Solver<D, K>;
    auto a = scene<D, K>(3, 0, emp::StressUpdate::corotational);
    ASSERT_TRUE(a->points().strain.empty());
    const double dt = 0.5 * a->criticalTimeStep();
    int erodingSteps = 0;
    const auto steps = [&](int n, Sv* b) {
        for (int k = 0; k < n; ++k) {
            const auto before = a->points().deformationGradient;
            a->step(dt, 1);
            if (b) b->step(dt, 2);
            if (!a->erosion()->lastEroded().empty()) {
                ++erodingSteps;
                expectEnergyOfTheLaw(*a, a->deformationInG2P() ? &before : nullptr);
            }
        }
    };
    steps(15, nullptr);
    std::stringstream archive;
    a->saveState(archive);
    EXPECT_EQ(countOf(archive.str(), "strain"), 0u);
    EXPECT_EQ(countOf(archive.str(), "deformationGradient"), a->points().size());
    auto b = Sv::loadState(archive);
    EXPECT_EQ(b->settings().stressUpdate, emp::StressUpdate::corotational);
    EXPECT_TRUE(b->points().strain.empty());
    expectSame(*a, *b);
    steps(25, b.get());
    expectSame(*a, *b);
    EXPECT_GT(a->erosion()->erodedCount(), 0u) << "the run should erode";
    EXPECT_GT(erodingSteps, 0);
}

TEST(StateTest2D, AStateOfVersion8WithTheCoRotatedStrainIsRestored)
{
    // Until version 9 the co-rotational update saved the co-rotated strain too: read and passed
    // over (the state's F gives the same numbers).
    using Sv = emp::Solver<2, emp::GimpKernel>;
    auto a = scene<2, emp::GimpKernel>(5, 0, emp::StressUpdate::corotational);
    const double dt = 0.5 * a->criticalTimeStep();
    for (int k = 0; k < 20; ++k) a->step(dt, 1);
    std::stringstream archive;
    a->saveState(archive);
    std::string bytes = withStresses(archive.str(), *a, 8);
    const auto& P = a->points();
    std::vector<double> strain;
    for (std::size_t p = 0; p < P.size(); ++p) {
        const emp::Sym2 t(P.strainOf(p));
        strain.insert(strain.end(), {t.xx, t.xy, t.yy});
    }
    std::string array = arrayOf(strain);
    const std::uint64_t n = P.size();
    std::memcpy(&array[0], &n, 8);
    bytes.replace(arrayAt(bytes, "strain"), 8, array);
    std::stringstream old(bytes);
    auto b = Sv::loadState(old);
    EXPECT_TRUE(b->points().strain.empty());
    expectSame(*a, *b);
    for (int k = 0; k < 10; ++k) {
        a->step(dt, 1);
        b->step(dt, 2);
    }
    expectSame(*a, *b);
    // A strain array of another length is refused.
    bytes.replace(arrayAt(bytes, "strain"), 8, arrayOf({0.0}).substr(0, 8));
    std::stringstream shorter(bytes);
    const std::string m = emptest::messageOf<emp::SimulationError>([&] { Sv::loadState(shorter); });
    EXPECT_TRUE(emptest::contains(m, "'strain' of another length")) << m;
}

TYPED_TEST(StateTest, AStateOfVersion9WithTheStressIsRestored)
{
    // Until version 10 the points' stresses were saved: read and passed over (the strain or F
    // and the damage give the same numbers: MaterialPoints::stressOf). One of another length is
    // refused.
    constexpr int D = TypeParam::D;
    using K = typename TypeParam::K;
    using Sv = emp::Solver<D, K>;
    for (auto u : {emp::StressUpdate::smallStrain, emp::StressUpdate::corotational}) {
        auto a = scene<D, K>(3, 0, u);
        const double dt = 0.5 * a->criticalTimeStep();
        for (int k = 0; k < 15; ++k) a->step(dt, 1);
        std::stringstream archive;
        a->saveState(archive);
        const std::string bytes = withStresses(archive.str(), *a, 9);
        EXPECT_GT(bytes.size(), archive.str().size() + a->points().size() * (D == 2 ? 24 : 72));
        std::stringstream old(bytes);
        auto b = Sv::loadState(old);
        expectSame(*a, *b);
        for (int k = 0; k < 10; ++k) {
            a->step(dt, 1);
            b->step(dt, 2);
        }
        expectSame(*a, *b);
        EXPECT_GT(a->erosion()->erodedCount(), 0u) << "the run should erode";
        std::string shorter = bytes;
        shorter.replace(arrayAt(shorter, "stress"), 8, arrayOf({0.0}).substr(0, 8));
        std::stringstream in(shorter);
        const std::string m = emptest::messageOf<emp::SimulationError>([&] { Sv::loadState(in); });
        EXPECT_TRUE(emptest::contains(m, "'stress' of another length")) << m;
    }
}

/// A condition with no saved form.
template <int D> struct Unsaveable : emp::GridCondition<D> {};

TYPED_TEST(StateTest, ConditionWithoutASavedFormIsRefusedAtSaveTime)
{
    auto a = scene<TypeParam::D, typename TypeParam::K>(5);
    a->addCondition(std::make_shared<Unsaveable<TypeParam::D>>());
    std::stringstream archive;
    const std::string m = emptest::messageOf<emp::SimulationError>([&] { a->saveState(archive); });
    EXPECT_TRUE(emptest::contains(m, "grid condition 1 is not a VelocityCondition")) << m;
}

}  // namespace
