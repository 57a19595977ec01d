// The registered constitutive laws: the one list. A material selects one by its index here
// (ElasticMaterial::law); Python offers them by name (ElasticMaterial(split=name)). Adding a
// law: a header under laws/ (start from laws/TemplateLaw.hpp), its include and its entry below.
#pragma once
#include <string>
#include <vector>

#include "Configurations.hpp"
#include "laws/NoSplit.hpp"
#include "laws/SpectralSplit.hpp"
#include "laws/VolumetricSplit.hpp"

namespace emp {

using RegisteredLaws = TypeList<SpectralSplit, VolumetricSplit, NoSplit>;

namespace detail {
template <class... L, class F> inline void withLaw(TypeList<L...>, int id, F&& f)
{
    int i = 0;
    (void)((i++ == id ? (f(L{}), true) : false) || ...);
}
template <class... L> inline std::vector<std::string> lawNames(TypeList<L...>) { return {L::name...}; }
}  // namespace detail

/// Calls f(Law{}) for the law with index `id` in RegisteredLaws: a switch, no virtual call.
template <class F> inline void withLaw(int id, F&& f) { detail::withLaw(RegisteredLaws{}, id, std::forward<F>(f)); }

/// The names of the registered laws, in index order.
inline std::vector<std::string> lawNames() { return detail::lawNames(RegisteredLaws{}); }

/// Index of the law called `name`, or -1.
inline int lawIndex(const std::string& name)
{
    const auto names = lawNames();
    for (std::size_t i = 0; i < names.size(); ++i)
        if (names[i] == name) return static_cast<int>(i);
    return -1;
}

/// The response of material m's law at strain eps (one dispatch).
template <int D> inline LawResponse<D> lawResponse(const Mat<D>& eps, const ElasticMaterial& m)
{
    LawResponse<D> r;
    withLaw(m.law, [&](auto law) { r = decltype(law)::template response<D>(eps, m); });
    return r;
}

}  // namespace emp
