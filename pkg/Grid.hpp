// Background grid: a regular Cartesian lattice of nodes with spacing h (struct of arrays).
#pragma once
#include <array>
#include <vector>

#include "ElasticMaterial.hpp"

namespace emp {

template <int D> struct Grid {
    Vec<D> origin = Vec<D>::Zero();  ///< coordinates of node (0, 0[, 0])
    double h = 0, invh = 0;
    std::array<int, D> n{};  ///< nodes per direction
    int stride[D] = {};      ///< index = sum_d i_d * stride[d]; x varies fastest

    std::vector<double> mass;      ///< m_I (Eq 12)
    std::vector<double> invMass;   ///< 1/m_I, or 0 below the small-mass cut-off
    std::vector<Vec<D>> momentum;  ///< P_I (Eqs 25, 29)
    std::vector<Vec<D>> velocity;  ///< v_I (Eq 26), then P_I^{n+1/2}/m_I for Eq 31
    std::vector<Vec<D>> force;     ///< f_I (Eqs 13, 28), then the applied f_I for Eq 30
    /// Node indices of the points near pre-existing cracks: the stencil of such a point reads
    /// its S^D node indices here (a twin in place of a marked node across the crack).
    std::vector<int> remap;

    /// Regular lattice nodes; phantom twins (pre-existing cracks) are numbered after them.
    int numNodes() const { return regular_; }
    /// Regular nodes plus phantom twins: the length of the nodal arrays.
    int totalNodes() const { return static_cast<int>(mass.size()); }
    /// Sizes the nodal arrays for `twins` phantom nodes after the regular ones.
    void setTwins(int twins)
    {
        const int total = regular_ + twins;
        if (totalNodes() == total) return;
        mass.resize(total, 0.0);
        invMass.resize(total, 0.0);
        momentum.resize(total, Vec<D>::Zero());
        velocity.resize(total, Vec<D>::Zero());
        force.resize(total, Vec<D>::Zero());
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
        mass.assign(total, 0.0);
        invMass.assign(total, 0.0);
        momentum.assign(total, Vec<D>::Zero());
        velocity.assign(total, Vec<D>::Zero());
        force.assign(total, Vec<D>::Zero());
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
    int regular_ = 0;
};

}  // namespace emp
