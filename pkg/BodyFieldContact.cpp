#include "BodyFieldContact.hpp"

#include "FieldPair.hpp"

namespace emp {

template <int D> template <bool onForce> int BodyFieldContact<D>::apply(Grid<D>& g, const PhantomNodes<D>& ph, double dt)
{
    int pairs = 0;
    std::vector<int> fields;
    for (int I : ph.markedNodes()) {
        fields.assign(1, I);
        ph.forEachTwin(I, [&](int t) { fields.push_back(t); });
        // Pairs in a fixed order (node, then field): sequential impulses, each conserving momentum.
        for (std::size_t a = 0; a < fields.size(); ++a)
            for (std::size_t b = a + 1; b < fields.size(); ++b) {
                const int fa = fields[a], fb = fields[b];
                if (g.invMass[fa] == 0 || g.invMass[fb] == 0) continue;
                Vec<D> e = gradient[fb] - gradient[fa];
                const double len = e.norm();
                if (!(len > 0)) continue;
                e /= len;
                if (fieldPairImpulse<D, onForce>(g, fa, fb, e, friction, dt)) ++pairs;
            }
    }
    return pairs;
}

template int BodyFieldContact<2>::apply<false>(Grid<2>&, const PhantomNodes<2>&, double);
template int BodyFieldContact<2>::apply<true>(Grid<2>&, const PhantomNodes<2>&, double);
template int BodyFieldContact<3>::apply<false>(Grid<3>&, const PhantomNodes<3>&, double);
template int BodyFieldContact<3>::apply<true>(Grid<3>&, const PhantomNodes<3>&, double);

}  // namespace emp
