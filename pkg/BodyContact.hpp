// Contact between the material points and rigid bodies (YADE's spheres, walls, facets and boxes,
// and the clumps they form), as a grid condition (GridCondition.hpp) applied after the forces.
//
// The formulation is grid-based and has no stiffness (doc/contact.md): after the forces, each
// node that a point touching a body reaches carries a trial velocity v* = (P + dt f) / m at
// t^{n+1/2}. Where v* approaches the body's surface velocity along the contact normal, an
// impulse J between the node and the body removes the approach (Bardenhagen et al.'s rigid-field
// contact, with the body's finite mass and inertia) and Coulomb friction caps the tangential
// impulse at mu |J_n|. The impulses are applied node by node in a fixed order (sequential
// impulses), each one updating the body's velocity before the next, so the exchange conserves
// momentum exactly between the two sides for any mass ratio. The node receives J / dt as a force;
// the body the opposite force and its moment about the body's centre, which the caller hands to
// YADE (O.forces) in the same step.
//
// Which nodes: a point is in contact with a shape when its signed distance to the surface is below
// its half-width (it touches it, paper Eq 16's particle domain); the nodes of its support are in
// contact, with the normal and contact point averaged over the touching points, weighted by N m.
// In 2D the model lies in the plane z = 0 and a body acts through its section by that plane.
#pragma once
#include <Eigen/Dense>
#include <vector>

#include "GridCondition.hpp"

namespace emp {

/// One rigid shape, in world coordinates at the current time.
struct RigidShape {
    enum Kind { sphere = 0, wall = 1, facet = 2, box = 3 };
    int kind = sphere;
    int body = 0;  ///< index in BodyContact::bodies of the rigid body that moves it
    /// sphere: centre; wall: a point of the plane; facet: first vertex; box: centre
    Eigen::Vector3d a = Eigen::Vector3d::Zero();
    /// wall: unit normal of the side that acts; facet: second vertex; box: half extents
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    Eigen::Vector3d c = Eigen::Vector3d::Zero();  ///< facet: third vertex
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< box: local to world
    double radius = 0;      ///< sphere
    bool twoSided = false;  ///< wall: both sides act (YADE's sense = 0)

    /// Signed distance from x to the surface (negative inside), the closest surface point s and
    /// the unit normal n pointing from the body towards x.
    void closest(const Eigen::Vector3d& x, double& phi, Eigen::Vector3d& s, Eigen::Vector3d& n) const;
    /// Lower and upper corners of the shape (a wall: the whole space on its plane's axis).
    void bounds(Eigen::Vector3d& lo, Eigen::Vector3d& hi) const;
};

/// The dynamic body a shape belongs to (a clump for its members), with the velocity it would have
/// at t^{n+1/2} without this contact.
struct RigidBody {
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
    Eigen::Vector3d angularVelocity = Eigen::Vector3d::Zero();
    Eigen::Vector3d invMass = Eigen::Vector3d::Zero();  ///< per direction; 0 when blocked or not dynamic
    Eigen::Matrix3d invInertia = Eigen::Matrix3d::Zero();  ///< world frame; 0 when rotations are blocked
    Eigen::Vector3d force = Eigen::Vector3d::Zero();   ///< result: force of the points on the body, N
    Eigen::Vector3d torque = Eigen::Vector3d::Zero();  ///< result: its moment about centre, N m
    int id = -1;  ///< the caller's id of the body (YADE's body id), or -1
    /// Its contact forces act through its centre (a frictionless sphere, centred in the plane
    /// z = 0 in 2D: each impulse lies along the radius to its contact point), so they have no
    /// moment and its spin and inertia play no part. The caller then gives it no angular
    /// velocity and no inverse inertia, and the stage leaves its torque zero (the moment of
    /// J along r, r x J, would only carry the rounding of r's direction).
    bool central = false;
};

template <int D> class BodyContact : public GridCondition<D> {
public:
    double friction = 0;  ///< Coulomb coefficient mu
    std::vector<RigidShape> shapes;
    std::vector<RigidBody> bodies;

    // Results of the last step.
    double work = 0;          ///< work of the contact forces on the points, J
    int pointsInContact = 0;  ///< points touching a shape
    int nodesInContact = 0;   ///< (shape, node) pairs with an impulse

    void afterForces(GridState<D>& s) override;

    /// Which of `candidates` would touch a point of `points` (the test of afterForces: a point
    /// of a cell in the shape's range whose signed distance is below `reach`); touched[k] is
    /// set to 1 for those, 0 for the others. Before a step, with the solver's points (which do
    /// not move before the contact stage) and its support's half-width, it tells the caller which
    /// bodies the stage will look at: a shape that touches no point receives no impulse, so its
    /// body's velocity, mass and inertia need not be read (doc/contact.md, "Cost").
    void touching(const Grid<D>& grid, const MaterialPoints<D>& points, double reach,
                  const std::vector<RigidShape>& candidates, std::vector<char>& touched);

private:
    struct Touch {
        int shape, node;
        double weight;  ///< N m
        Eigen::Vector3d normal, point;  ///< weighted sums
    };
    struct Range {
        int lo[3], hi[3];  ///< cells a shape's points may lie in
        bool live;         ///< false: none (outside the grid, or off the plane z = 0 in 2D)
    };
    std::vector<Touch> touches_;
    std::vector<Range> ranges_;
    int binLo_[3] = {0, 0, 0}, binHi_[3] = {0, 0, 0};  ///< the binned cells: the union of the ranges
    std::vector<int> cellStart_, cellPoints_, cellOf_, fill_, candidates_, rowPoints_;
    bool cellRange(const Grid<D>& g, const RigidShape& shape, double reach, int lo[3], int hi[3]) const;
    /// The cell range of each of `list`, and the points of their union binned by cell; false when
    /// no shape's range lies in the grid. With `support` (in the step), only the points it names
    /// for the union's rows are tested (PointSupport::pointsInRows), otherwise every point.
    bool binNear(const Grid<D>& g, const MaterialPoints<D>& P, double reach, const std::vector<RigidShape>& list,
                 const PointSupport<D>* support = nullptr);
    void binPoints(const Grid<D>& g, const MaterialPoints<D>& P, const PointSupport<D>* support);
    /// Calls f(k, p, x) for every point p of the cells in the range of list[k] (binNear first)
    /// that may lie within `reach` of it, shape by shape, cell by cell, in point order within a
    /// cell; x is p's position in 3D. f returns false to go on to the next shape.
    template <class F>
    void forEachNear(const std::vector<RigidShape>& list, const MaterialPoints<D>& P, double reach, F&& f) const;
};

}  // namespace emp
