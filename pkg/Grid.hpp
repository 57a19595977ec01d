// Background grid: a regular Cartesian lattice of nodes with spacing h (struct of arrays).
#pragma once
#include <array>
#include <vector>

#include "ElasticMaterial.hpp"
#include "ZeroPages.hpp"

namespace emp {

template <int D> struct Grid {
    Vec<D> origin = Vec<D>::Zero();  ///< coordinates of node (0, 0[, 0])
    double h = 0, invh = 0;
    std::array<int, D> n{};  ///< nodes per direction
    int stride[D] = {};      ///< index = sum_d i_d * stride[d]; x varies fastest

    // The nodal arrays start as zeros that are not written (ZeroPages): a rank of a distributed
    // run writes only its planes, and only those take memory.
    template <class T> using Nodal = std::vector<T, ZeroPages<T>>;
    Nodal<double> mass;      ///< m_I (Eq 12)
    Nodal<double> invMass;   ///< 1/m_I, or 0 below the small-mass cut-off
    Nodal<Vec<D>> momentum;  ///< P_I (Eqs 25, 29)
    Nodal<Vec<D>> velocity;  ///< v_I (Eq 26), then P_I^{n+1/2}/m_I for Eq 31
    Nodal<Vec<D>> force;     ///< f_I (Eqs 13, 28), then the applied f_I for Eq 30
    /// 3D: P2G's sums, node by node m_I then P_I (sumsWidth = 4 numbers from I * sumsWidth
    /// on): one 4-lane vector per node (32-byte aligned where ZeroPages maps pages, above 1 MB),
    /// which P2G updates in one addition (Stencil::scatterRowsOf). nodalVelocity copies them
    /// into mass and momentum. (2D: empty; P2G adds into mass and momentum directly, which
    /// measured as fast: doc/performance.md, "Session 42".)
    static constexpr int sumsWidth = D == 3 ? 4 : 0;
    Nodal<double> massMomentum;
    /// Node indices of the points near pre-existing cracks: the stencil of such a point reads
    /// its S^D node indices here (a twin in place of a marked node across the crack).
    std::vector<int> remap;

    /// Regular lattice nodes; phantom twins (pre-existing cracks) are numbered after them.
    int numNodes() const { return regular_; }
    /// Regular nodes plus phantom twins: the length of the nodal arrays.
    int totalNodes() const { return static_cast<int>(mass.size()); }
    /// Sizes the nodal arrays for `twins` phantom nodes after the regular ones. The step calls it
    /// before it clears the grid: when the arrays must grow beyond their capacity, they are
    /// allocated anew as zeros, without copying (copying would write, and so back with memory,
    /// every page of the whole grid).
    void setTwins(int twins)
    {
        const int total = regular_ + twins;
        if (totalNodes() == total) return;
        if (static_cast<std::size_t>(total) > mass.capacity()) {
            allocate(total, regular_ + 2 * twins);  // (room to grow: a growing crack adds twins step by step)
            return;
        }
        mass.resize(total, 0.0);
        invMass.resize(total, 0.0);
        momentum.resize(total, Vec<D>::Zero());
        velocity.resize(total, Vec<D>::Zero());
        force.resize(total, Vec<D>::Zero());
        massMomentum.resize(static_cast<std::size_t>(total) * sumsWidth, 0.0);
    }

    /// Nodes at origin + i*h for i in [0, n); resets every nodal array.
    void resize(const Vec<D>& org, double spacing, const std::array<int, D>& nodes)
    {
        origin = org;
        h = spacing;
        invh = 1.0 / spacing;
        n = nodes;
        int total = 1;
        for (int d = 0; d < D; ++d) {
            stride[d] = total;
            total *= n[d];
        }
        regular_ = total;
        allocate(total);
    }

    /// Position of a regular node (a twin sits at the position of its node).
    Vec<D> nodePosition(int index) const
    {
        Vec<D> x;
        for (int d = D - 1; d >= 0; --d) {
            const int i = index / stride[d];
            index -= i * stride[d];
            x[d] = origin[d] + i * h;
        }
        return x;
    }

    /// Index of the node nearest to x, or -1 when x is outside the grid.
    int nearestNode(const Vec<D>& x) const
    {
        int index = 0;
        for (int d = 0; d < D; ++d) {
            const double xi = (x[d] - origin[d]) * invh;
            if (!(xi > -0.5 && xi < n[d] - 0.5)) return -1;
            index += static_cast<int>(xi + 0.5) * stride[d];
        }
        return index;
    }

private:
    /// Fresh nodal arrays of `total` zeros (room for `capacity`), not written.
    void allocate(int total, int capacity = 0)
    {
        freshZeros(mass, total, capacity);
        freshZeros(invMass, total, capacity);
        freshZeros(momentum, total, capacity);
        freshZeros(velocity, total, capacity);
        freshZeros(force, total, capacity);
        freshZeros(massMomentum, static_cast<std::size_t>(total) * sumsWidth, static_cast<std::size_t>(capacity) * sumsWidth);
    }
    int regular_ = 0;
};

}  // namespace emp
