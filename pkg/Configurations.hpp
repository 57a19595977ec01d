// The (dimension, shape function) pairs the product is built for: the one list. Solver.cpp
// and CrackTransport.cpp instantiate them, the Python module exposes them, the typed tests run
// on them. To build a new kernel, add one X(D, Kernel) entry per dimension here.
#pragma once
#include "ShapeFunction.hpp"

#define EMP_SOLVER_CONFIGURATIONS(X) \
    X(2, LinearKernel)               \
    X(2, GimpKernel)                 \
    X(3, LinearKernel)               \
    X(3, GimpKernel)

namespace emp {

/// A list of types (the configurations, the laws) that templates can expand.
template <class... T> struct TypeList {
    static constexpr int size = sizeof...(T);
};

/// A (dimension, kernel) pair as a type.
template <int D_, class K_> struct Configuration {
    static constexpr int D = D_;
    using Kernel = K_;
};

namespace detail {
template <class L> struct DropFirst;
template <class F, class... T> struct DropFirst<TypeList<F, T...>> {
    using type = TypeList<T...>;
};
}  // namespace detail

#define EMP_CONFIGURATION_TYPE(D, K) , Configuration<D, K>
/// Every configuration of EMP_SOLVER_CONFIGURATIONS, in its order.
using Configurations = typename detail::DropFirst<TypeList<void EMP_SOLVER_CONFIGURATIONS(EMP_CONFIGURATION_TYPE)>>::type;
#undef EMP_CONFIGURATION_TYPE

}  // namespace emp
