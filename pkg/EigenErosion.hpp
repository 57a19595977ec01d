// Eigenerosion (paper Section 3.3.2, Eqs 17-24 and 33; search of Section 4.2). After the stress
// update of a step, a point p erodes when its effective energy release rate
//     G_p = alpha kappa (sum_q m_q H_q) / (sum_q m_q)       (Eq 23, q intact, |x_q - x_p| <= kappa)
// reaches Gc (Eq 24). Every point qualifying in a step erodes at once, so the eroded set does not
// depend on the order of the points or on the thread count. An eroded point keeps only the
// compressive stress sigma- (g(c) = c = 0) for ever. Because G_p <= alpha kappa max_q H_q, a step
// in which alpha kappa H < Gc at every intact point needs no neighbour search at all, and only
// points within kappa of a point with alpha kappa H >= Gc (a source) can erode.
#pragma once
#include <cstdint>
#include <vector>

#include "Archive.hpp"
#include "CellList.hpp"
#include "Distribution.hpp"
#include "ElasticMaterial.hpp"
#include "GridCondition.hpp"
#include "MaterialPoints.hpp"

namespace emp {

struct ErosionSettings {
    double Gc = 0;     ///< critical energy release rate, J/m2
    double alpha = 0;  ///< normalising constant (paper: 1 to 2)
    double kappa = 0;  ///< neighbourhood radius, m
};

/// One erosion event: which point, in which step, at which time.
struct ErosionEvent {
    int point;
    std::int64_t step;
    double time;
};

template <int D> class EigenErosion {
public:
    /// Validates Gc, alpha, kappa > 0 (finite).
    explicit EigenErosion(const ErosionSettings& s);

    /// Evaluates Eq 23 where needed and erodes the points with G_p >= Gc. Returns how many eroded.
    /// A distributed run (Distribution.hpp) gives the neighbours' points near this rank
    /// (`ghosts`) and its transport: every rank must call it; the eroded set, the events and the
    /// dissipated energy are then those of the single-process run, on every rank (events name
    /// the points by globalId).
    ///
    /// Given the step's `rows` (the solver's points by cell row, on grid `g`), the neighbour
    /// list scans only the points of the rows of the sources' box instead of every point: the
    /// same list.
    int apply(MaterialPoints<D>& P, const std::vector<ElasticMaterial>& materials, std::int64_t step,
              double time, int nThreads, const GhostPoints<D>* ghosts = nullptr, Transport* transport = nullptr,
              const PointSupport<D>* rows = nullptr, const Grid<D>* g = nullptr);

    /// G_p of every listed point by brute force over all intact points (for tests and
    /// diagnostics; O(N^2)).
    std::vector<double> energyReleaseRateBruteForce(const MaterialPoints<D>& P, const std::vector<int>& ids) const;
    /// G_p of the listed points with the cell list over all intact points.
    std::vector<double> energyReleaseRate(const MaterialPoints<D>& P, const std::vector<int>& ids);

    const ErosionSettings& settings() const { return settings_; }
    /// A point is a source (alpha kappa H >= Gc, and intact) when its history reaches this.
    double sourceHistory() const { return settings_.Gc / (settings_.alpha * settings_.kappa); }
    bool isSource(double history, double damage) const { return history >= sourceHistory() && damage > 0; }
    /// What apply() does in a step in which no point is a source (the caller has tested every
    /// point with isSource after the stress update): no search, nothing eroded.
    void noSources()
    {
        sources_.clear();
        candidates_.clear();
        eroding_.clear();
        before_.clear();
        searched_ = false;
    }
    double dissipatedEnergy() const { return dissipated_; }  ///< Eq 33, J
    std::size_t erodedCount() const { return events_.size(); }
    const std::vector<ErosionEvent>& events() const { return events_; }
    bool searchedLastStep() const { return searched_; }   ///< whether the last apply() searched
    std::size_t candidatesLastStep() const { return candidates_.size(); }
    /// Points eroded by the last apply(), ascending, and their stress just before erosion.
    const std::vector<int>& lastEroded() const { return eroding_; }
    const std::vector<Mat<D>>& stressBeforeErosion() const { return before_; }

    /// The state a restart needs (dissipated energy, events, the last step's search flag);
    /// the settings are saved by the caller, which constructs the stage with them.
    void saveState(ArchiveWriter& w) const
    {
        w.value(dissipated_);
        w.array(events_);
        w.value(searched_);
    }
    void loadState(ArchiveReader& r)
    {
        dissipated_ = r.value<double>();
        r.array(events_);
        searched_ = r.value<bool>();
    }

private:
    template <class V>
    void buildList(const V& view, Vec<D> lo, Vec<D> hi, const PointSupport<D>* rows = nullptr, const Grid<D>* g = nullptr);
    template <class V> double rate(const V& view, int p) const;

    ErosionSettings settings_;
    double dissipated_ = 0;
    std::vector<ErosionEvent> events_;
    bool searched_ = false;
    CellList<D> cells_;
    std::vector<int> sources_, binned_, candidates_, eroding_, rowPoints_;
    std::vector<Mat<D>> before_;
    std::vector<char> mark_;
};

}  // namespace emp
