// An allocator for arrays that start as zeros and are written only in part: the grid's nodal
// arrays. A rank of a distributed run works on its own node planes only (Distribution.hpp), so
// the rest of its grid is never written; with this allocator those pages are never backed by
// memory (doc/parallel.md, "Memory").
#pragma once
#include <sys/mman.h>

#include <cstddef>
#include <cstdlib>
#include <new>
#include <utility>
#include <vector>

namespace emp {

/// Large blocks come from anonymous mmap: pages of zeros that the OS backs with memory only when
/// written. Small blocks come from calloc. resize(n) without a value leaves the new elements as
/// these zero bytes without writing them (0.0 for doubles and Eigen vectors of doubles), so it
/// gives zeros only on fresh memory: use it on an empty vector with no capacity, as
/// Grid::resize does; resize(n, value) and the other members behave as usual.
template <class T> struct ZeroPages {
    using value_type = T;
    static constexpr std::size_t mapped = std::size_t(1) << 20;  ///< bytes from which mmap is used
    /// Bytes allocated after the last element, so that a 32-byte vector load from any element
    /// stays in the block (Lane3::load reads a 3-vector with the next 8 bytes).
    static constexpr std::size_t tail = 32;

    ZeroPages() = default;
    template <class U> ZeroPages(const ZeroPages<U>&) noexcept {}

    T* allocate(std::size_t n)
    {
        const std::size_t bytes = n * sizeof(T) + tail;
        void* p = nullptr;
        if (bytes >= mapped) {
            p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
            if (p == MAP_FAILED) throw std::bad_alloc();
        } else {
            p = std::calloc(bytes, 1);
            if (!p) throw std::bad_alloc();
        }
        return static_cast<T*>(p);
    }
    void deallocate(T* p, std::size_t n) noexcept
    {
        if (n * sizeof(T) + tail >= mapped)
            munmap(p, n * sizeof(T) + tail);
        else
            std::free(p);
    }
    /// Default construction writes nothing: the bytes are zeros already (see above).
    template <class U> void construct(U*) noexcept {}
    template <class U, class... A> void construct(U* p, A&&... a) { ::new (static_cast<void*>(p)) U(std::forward<A>(a)...); }

    friend bool operator==(const ZeroPages&, const ZeroPages&) { return true; }
    friend bool operator!=(const ZeroPages&, const ZeroPages&) { return false; }
};

/// Replaces `a` by n elements of zero bytes on fresh memory of `capacity` (at least n) elements,
/// without writing them.
template <class T> void freshZeros(std::vector<T, ZeroPages<T>>& a, std::size_t n, std::size_t capacity = 0)
{
    std::vector<T, ZeroPages<T>>().swap(a);
    a.reserve(capacity > n ? capacity : n);
    a.resize(n);
}

}  // namespace emp
