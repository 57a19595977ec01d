// The Transport of a distributed run (pkg/Distribution.hpp) over MPI: the ranks of
// MPI_COMM_WORLD in a line. Built only where MPI is found (CMake option EMP_MPI).
#pragma once
#include <mpi.h>

#include "Distribution.hpp"

namespace emp {

class MpiTransport : public Transport {
public:
    /// Initialises MPI if nobody did (mpi4py may have), and finalises it at exit then.
    MpiTransport();
    int rank() const override { return rank_; }
    int size() const override { return size_; }
    void exchange(const std::vector<char>& toLeft, const std::vector<char>& toRight, std::vector<char>& fromLeft,
                  std::vector<char>& fromRight) override;
    void sum(double* v, int n) override;
    void max(double* v, int n) override;
    std::vector<std::vector<char>> allGather(const std::vector<char>& mine) override;
    std::vector<std::vector<char>> allToAll(const std::vector<std::vector<char>>& toEach) override;
    std::vector<std::vector<char>> neighbourExchange(const std::vector<int>& ranks,
                                                     const std::vector<std::vector<char>>& out) override;

private:
    MPI_Comm comm_;
    int rank_ = 0, size_ = 1;
};

}  // namespace emp
