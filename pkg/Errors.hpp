// Exceptions of the core. Boost.Python maps std::invalid_argument to ValueError and
// std::runtime_error to RuntimeError, so a YADE script sees a normal Python exception.
#pragma once
#include <sstream>
#include <stdexcept>
#include <string>

namespace emp {

/// A user parameter outside its allowed range: the message names it, its value and the range.
struct ParameterError : std::invalid_argument {
    using std::invalid_argument::invalid_argument;
};

/// The simulation cannot go on (a point left the grid, a value became NaN, dt too large).
struct SimulationError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

/// Throws ParameterError unless ok: "EigenMPM: <name> = <value> is invalid; allowed: <range>".
template <class T>
void require(bool ok, const std::string& name, const T& value, const std::string& range)
{
    if (ok) return;
    std::ostringstream s;
    s.precision(10);
    s << "EigenMPM: " << name << " = " << value << " is invalid; allowed: " << range;
    throw ParameterError(s.str());
}

}  // namespace emp
