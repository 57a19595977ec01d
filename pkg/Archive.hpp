// Binary archives of a run's state (Solver::saveState / loadState): plain values and arrays of
// trivially copyable values, in the machine's byte order, behind a header naming the format and
// its version. A reader refuses, with a message saying what it expected, any archive that is
// truncated, of another format or version, or written for another configuration: a state that
// cannot be restored is never replaced by a partial one.
#pragma once
#include <cstdint>
#include <istream>
#include <ostream>
#include <string>
#include <type_traits>
#include <vector>

#include <Eigen/Core>

#include "Errors.hpp"

namespace emp {

/// Values stored as their bytes: trivially copyable types and Eigen's fixed-size matrices of
/// arithmetic scalars (a plain array of coefficients, copyable bytewise though not "trivially").
template <class T> struct IsPlain : std::is_trivially_copyable<T> {};
template <class S, int R, int C, int O, int MR, int MC>
struct IsPlain<Eigen::Matrix<S, R, C, O, MR, MC>>
    : std::integral_constant<bool, std::is_arithmetic<S>::value && R != Eigen::Dynamic && C != Eigen::Dynamic> {};

class ArchiveWriter {
public:
    explicit ArchiveWriter(std::ostream& os) : os_(os) {}
    template <class T> void value(const T& v)
    {
        static_assert(IsPlain<T>::value, "plain values only");
        os_.write(reinterpret_cast<const char*>(&v), sizeof(T));
    }
    template <class T> void array(const std::vector<T>& a)
    {
        static_assert(IsPlain<T>::value, "arrays of plain values only");
        value<std::uint64_t>(a.size());
        if (!a.empty()) os_.write(reinterpret_cast<const char*>(a.data()), sizeof(T) * a.size());
    }
    void string(const std::string& s)
    {
        value<std::uint64_t>(s.size());
        os_.write(s.data(), static_cast<std::streamsize>(s.size()));
    }

private:
    std::ostream& os_;
};

class ArchiveReader {
public:
    explicit ArchiveReader(std::istream& is) : is_(is) {}
    template <class T> T value()
    {
        T v;
        read(&v, sizeof(T));
        return v;
    }
    template <class T> void array(std::vector<T>& a)
    {
        const auto n = value<std::uint64_t>();
        if (n > (std::uint64_t(1) << 40) / sizeof(T)) fail("an array of " + std::to_string(n) + " elements");
        a.resize(n);
        if (n) read(a.data(), sizeof(T) * n);
    }
    std::string string()
    {
        const auto n = value<std::uint64_t>();
        if (n > 4096) fail("a name of " + std::to_string(n) + " characters");
        std::string s(n, '\0');
        if (n) read(&s[0], n);
        return s;
    }
    /// Reads a name and refuses the archive unless it is `expected` (a section or field tag).
    void expect(const std::string& expected)
    {
        const std::string got = string();
        if (got != expected) fail("'" + got + "' where '" + expected + "' belongs");
    }
    [[noreturn]] void fail(const std::string& what) const
    {
        throw SimulationError("EigenMPM: the saved state cannot be restored: it holds " + what +
                              "; it was written by another version of EigenMPM or is damaged");
    }

private:
    void read(void* p, std::size_t n)
    {
        is_.read(static_cast<char*>(p), static_cast<std::streamsize>(n));
        if (static_cast<std::size_t>(is_.gcount()) != n) fail("fewer bytes than its contents need (truncated)");
    }
    std::istream& is_;
};

}  // namespace emp
