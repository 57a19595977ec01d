#include "MpiTransport.hpp"

#include <cstdlib>

namespace emp {

namespace {

void finalize()
{
    int done = 0;
    MPI_Finalized(&done);
    if (!done) MPI_Finalize();
}

}  // namespace

MpiTransport::MpiTransport()
{
    int ready = 0;
    MPI_Initialized(&ready);
    if (!ready) {
        int provided = 0;
        MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
        std::atexit(finalize);
    }
    // A communicator of our own: our messages never meet the user's (or yade.mpy's).
    MPI_Comm_dup(MPI_COMM_WORLD, &comm_);
    MPI_Comm_rank(comm_, &rank_);
    MPI_Comm_size(comm_, &size_);
}

void MpiTransport::exchange(const std::vector<char>& toLeft, const std::vector<char>& toRight,
                            std::vector<char>& fromLeft, std::vector<char>& fromRight)
{
    // Sizes first, then the bytes; both directions at once.
    const int left = rank_ > 0 ? rank_ - 1 : MPI_PROC_NULL, right = rank_ < size_ - 1 ? rank_ + 1 : MPI_PROC_NULL;
    long out[2] = {static_cast<long>(toLeft.size()), static_cast<long>(toRight.size())}, in[2] = {0, 0};
    MPI_Request req[4];
    MPI_Irecv(&in[0], 1, MPI_LONG, left, 1, comm_, &req[0]);
    MPI_Irecv(&in[1], 1, MPI_LONG, right, 0, comm_, &req[1]);
    MPI_Isend(&out[0], 1, MPI_LONG, left, 0, comm_, &req[2]);
    MPI_Isend(&out[1], 1, MPI_LONG, right, 1, comm_, &req[3]);
    MPI_Waitall(4, req, MPI_STATUSES_IGNORE);
    fromLeft.assign(left == MPI_PROC_NULL ? 0 : in[0], 0);
    fromRight.assign(right == MPI_PROC_NULL ? 0 : in[1], 0);
    MPI_Irecv(fromLeft.data(), static_cast<int>(fromLeft.size()), MPI_BYTE, left, 3, comm_, &req[0]);
    MPI_Irecv(fromRight.data(), static_cast<int>(fromRight.size()), MPI_BYTE, right, 2, comm_, &req[1]);
    MPI_Isend(toLeft.data(), static_cast<int>(toLeft.size()), MPI_BYTE, left, 2, comm_, &req[2]);
    MPI_Isend(toRight.data(), static_cast<int>(toRight.size()), MPI_BYTE, right, 3, comm_, &req[3]);
    MPI_Waitall(4, req, MPI_STATUSES_IGNORE);
}

void MpiTransport::sum(double* v, int n) { MPI_Allreduce(MPI_IN_PLACE, v, n, MPI_DOUBLE, MPI_SUM, comm_); }

void MpiTransport::max(double* v, int n) { MPI_Allreduce(MPI_IN_PLACE, v, n, MPI_DOUBLE, MPI_MAX, comm_); }

std::vector<std::vector<char>> MpiTransport::allGather(const std::vector<char>& mine)
{
    int n = static_cast<int>(mine.size());
    std::vector<int> counts(size_), offsets(size_, 0);
    MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, comm_);
    for (int r = 1; r < size_; ++r) offsets[r] = offsets[r - 1] + counts[r - 1];
    std::vector<char> all(offsets[size_ - 1] + counts[size_ - 1]);
    MPI_Allgatherv(mine.data(), n, MPI_BYTE, all.data(), counts.data(), offsets.data(), MPI_BYTE, comm_);
    std::vector<std::vector<char>> out(size_);
    for (int r = 0; r < size_; ++r) out[r].assign(all.begin() + offsets[r], all.begin() + offsets[r] + counts[r]);
    return out;
}

std::vector<std::vector<char>> MpiTransport::allToAll(const std::vector<std::vector<char>>& toEach)
{
    std::vector<int> sendCounts(size_), recvCounts(size_), sendOffsets(size_, 0), recvOffsets(size_, 0);
    for (int r = 0; r < size_; ++r) sendCounts[r] = static_cast<int>(toEach[r].size());
    MPI_Alltoall(sendCounts.data(), 1, MPI_INT, recvCounts.data(), 1, MPI_INT, comm_);
    for (int r = 1; r < size_; ++r) {
        sendOffsets[r] = sendOffsets[r - 1] + sendCounts[r - 1];
        recvOffsets[r] = recvOffsets[r - 1] + recvCounts[r - 1];
    }
    std::vector<char> out(sendOffsets[size_ - 1] + sendCounts[size_ - 1]), in(recvOffsets[size_ - 1] + recvCounts[size_ - 1]);
    for (int r = 0; r < size_; ++r) std::copy(toEach[r].begin(), toEach[r].end(), out.begin() + sendOffsets[r]);
    MPI_Alltoallv(out.data(), sendCounts.data(), sendOffsets.data(), MPI_BYTE, in.data(), recvCounts.data(),
                  recvOffsets.data(), MPI_BYTE, comm_);
    std::vector<std::vector<char>> from(size_);
    for (int r = 0; r < size_; ++r) from[r].assign(in.begin() + recvOffsets[r], in.begin() + recvOffsets[r] + recvCounts[r]);
    return from;
}

std::vector<std::vector<char>> MpiTransport::neighbourExchange(const std::vector<int>& ranks,
                                                             const std::vector<std::vector<char>>& out)
{
    // Sizes first, then the bytes, with every neighbour at once (tags of their own: the line's
    // exchange uses 0 to 3).
    const int n = static_cast<int>(ranks.size());
    std::vector<long> sizeOut(n), sizeIn(n, 0);
    std::vector<MPI_Request> req(2 * static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
        sizeOut[i] = static_cast<long>(out[i].size());
        MPI_Irecv(&sizeIn[i], 1, MPI_LONG, ranks[i], 4, comm_, &req[2 * i]);
        MPI_Isend(&sizeOut[i], 1, MPI_LONG, ranks[i], 4, comm_, &req[2 * i + 1]);
    }
    MPI_Waitall(2 * n, req.data(), MPI_STATUSES_IGNORE);
    std::vector<std::vector<char>> in(n);
    for (int i = 0; i < n; ++i) {
        in[i].assign(sizeIn[i], 0);
        MPI_Irecv(in[i].data(), static_cast<int>(sizeIn[i]), MPI_BYTE, ranks[i], 5, comm_, &req[2 * i]);
        MPI_Isend(out[i].data(), static_cast<int>(out[i].size()), MPI_BYTE, ranks[i], 5, comm_, &req[2 * i + 1]);
    }
    MPI_Waitall(2 * n, req.data(), MPI_STATUSES_IGNORE);
    return in;
}

}  // namespace emp
