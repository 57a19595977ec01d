// Grid conditions: objects the step applies at named points, in the order they were added.
//
//   afterNodalVelocity  after P2G and the nodal velocity v_I = P_I / m_I (Eq 26), before the
//                       strain increment (Eq 27): the grid holds mass, momentum P^{n-1/2} and
//                       velocity; a condition sets momentum and velocity (essential conditions),
//                       at t = t^{n-1/2}. (With APIC and the co-rotational update together, P2G
//                       has added the internal and body forces already: the force is read or
//                       replaced after the forces.)
//   afterForces         after the internal, body and traction forces (Eqs 13, 14, 28), before
//                       the nodal update P^{n+1/2} = P^{n-1/2} + dt f (Eq 29): the grid holds
//                       the force; a condition replaces it by the force it needs (and may record
//                       the difference as its reaction), at t = t^{n+1/2}.
//
// Velocity conditions (prescribed, fixed, symmetry/roller) are such objects
// (VelocityCondition.hpp). Contact, or a second velocity field at a crack, is added the same way:
// a class deriving from GridCondition<D>, registered with Solver::addCondition; the step does
// not change. A condition runs once per step, not per point, so a virtual call is cheap here.
#pragma once
#include <climits>
#include <functional>
#include <vector>

#include "Grid.hpp"
#include "MaterialPoints.hpp"
#include "PhantomNodes.hpp"

namespace emp {

/// The support of single points (their nodes and weights, phantom twins across cracks included),
/// for conditions that act through the points (contact, BodyContact.hpp). One call per point:
/// meant for the few points a condition touches, not for every point.
template <int D> class PointSupport {
public:
    virtual ~PointSupport() = default;
    /// Calls f(node index, N) for every node of point p's support.
    virtual void forEachNode(int p, const std::function<void(int, double)>& f) const = 0;
    /// Half-width of a point's domain, m (uGIMP's particle half-width; half the point spacing).
    virtual double halfWidth() const = 0;
    /// Writes into `ids`, in increasing order, the points whose cell along the last axis lies in
    /// the rows [lo, hi] (cell row c holds floor((x - origin) / h) = c), and possibly others: the
    /// caller tests each.
    virtual void pointsInRows(int lo, int hi, std::vector<int>& ids) const = 0;
};

/// What a condition sees at its point of the step.
template <int D> struct GridState {
    Grid<D>& grid;
    const MaterialPoints<D>& points;
    const PhantomNodes<D>& phantom;  ///< twins of the marked nodes (pre-existing cracks)
    double time;                     ///< t^{n-1/2} after the nodal velocity, t^{n+1/2} after forces
    double dt;
    const PointSupport<D>* support = nullptr;  ///< the points' supports (set after the forces)
    /// The nodes [ownedLo, ownedHi) this process owns: a sum over nodes (a reaction) counts only
    /// those, so that a distributed run (Distribution.hpp) counts every node once; with columns
    /// of ranks, only those of them whose index along the first axis is in [ownedColumnLo,
    /// ownedColumnHi).
    int ownedLo = 0, ownedHi = INT_MAX, ownedColumnLo = 0, ownedColumnHi = INT_MAX;
    /// Whether this process owns the regular node I.
    bool owns(int I) const
    {
        if (I < ownedLo || I >= ownedHi) return false;
        if (ownedColumnLo == 0 && ownedColumnHi == INT_MAX) return true;
        const int i0 = I % grid.n[0];
        return i0 >= ownedColumnLo && i0 < ownedColumnHi;
    }
};

template <int D> class GridCondition {
public:
    virtual ~GridCondition() = default;
    virtual void afterNodalVelocity(GridState<D>&) {}
    virtual void afterForces(GridState<D>&) {}
    /// Whether the condition reads and writes only regular nodes it can name before the step,
    /// the lowest and highest of them in [lo, hi] (lo > hi: none). A step as a wavefront
    /// (Solver::pipelineLoop) then applies it once every row of those nodes is final, before
    /// anything reads them. The default, false (it reads the points, the twins or other state),
    /// makes every step with it run pass by pass.
    virtual bool nodeRange(int& lo, int& hi) const
    {
        (void)lo, (void)hi;
        return false;
    }
};

}  // namespace emp
