#include "Lanes.hpp"

#include <algorithm>
#include <cstdlib>

namespace emp {

LaneIsa processorLaneIsa()
{
#ifdef EMP_LANES_X86
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq")) return LaneIsa::avx512;
    if (__builtin_cpu_supports("avx2")) return LaneIsa::avx2;
#endif
    return LaneIsa::baseline;
}

const char* name(LaneIsa isa)
{
    return isa == LaneIsa::avx512 ? "avx512" : isa == LaneIsa::avx2 ? "avx2" : "baseline";
}

bool laneIsaOf(const std::string& s, LaneIsa& isa)
{
    if (s == "auto") isa = processorLaneIsa();
    else if (s == "avx512") isa = LaneIsa::avx512;
    else if (s == "avx2") isa = LaneIsa::avx2;
    else if (s == "baseline") isa = LaneIsa::baseline;
    else return false;
    return true;
}

namespace {
int startingIsa()
{
    LaneIsa isa = processorLaneIsa();
    LaneIsa cap;
    if (const char* e = std::getenv("EIGENMPM_LANES"); e && laneIsaOf(e, cap))
        isa = static_cast<LaneIsa>(std::min(static_cast<int>(isa), static_cast<int>(cap)));
    return static_cast<int>(isa);
}
}  // namespace

namespace lanes {
std::atomic<int> now{startingIsa()};
}

LaneIsa setLaneIsa(LaneIsa isa)
{
    const int v = std::min(static_cast<int>(isa), static_cast<int>(processorLaneIsa()));
    lanes::now.store(v, std::memory_order_relaxed);
    return static_cast<LaneIsa>(v);
}

}  // namespace emp
