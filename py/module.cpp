// Boost.Python bindings of the core: one Python class per (dimension, shape function) pair.
// Vectors are taken as any 2- or 3-sequence (YADE's Vector3, tuples, lists, numpy arrays);
// bulk per-point data travels as numpy arrays. The Python package eigenmpm wraps these classes
// in YADE engines.
#include <boost/python.hpp>
#include <boost/python/numpy.hpp>
#include <cctype>
#include <cstdint>
#include <ctime>
#include <limits>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "BodyContact.hpp"
#include "CrackFront.hpp"
#include "EigenErosion.hpp"
#include "ErosionCalibration.hpp"
#include "Errors.hpp"
#include "Lanes.hpp"
#include "Laws.hpp"
#include "MpiTransport.hpp"
#include "Solver.hpp"

namespace bp = boost::python;
namespace np = boost::python::numpy;
using namespace emp;

namespace {

Eigen::Vector3d toVec3(const bp::object& o, const char* what)
{
    const long n = bp::len(o);
    require(n == 2 || n == 3, std::string(what) + " (vector length)", n, "2 or 3 components");
    Eigen::Vector3d v = Eigen::Vector3d::Zero();
    for (long i = 0; i < n; ++i) v[i] = bp::extract<double>(o[i]);
    return v;
}

bp::tuple fromVec3(const Eigen::Vector3d& v) { return bp::make_tuple(v[0], v[1], v[2]); }

/// A YADE Vector3 (read in place: it wraps an Eigen::Vector3d, registered by YADE) or, failing
/// that, any 2- or 3-sequence.
Eigen::Vector3d fastVec3(const bp::object& o, const char* what)
{
    bp::extract<const Eigen::Vector3d&> inPlace(o);
    if (inPlace.check()) return inPlace();
    bp::extract<Eigen::Vector3d> converted(o);
    return converted.check() ? converted() : toVec3(o, what);
}

/// f(arg), one positional argument, without building an argument tuple.
bp::object callOne(const bp::object& f, const bp::object& arg)
{
    PyObject* r = PyObject_CallOneArg(f.ptr(), arg.ptr());
    if (!r) bp::throw_error_already_set();
    return bp::object(bp::handle<>(r));
}

/// Attribute `key` (an interned name, made once by the caller) of o.
bp::object attr(const bp::object& o, PyObject* key)
{
    PyObject* r = PyObject_GetAttr(o.ptr(), key);
    if (!r) bp::throw_error_already_set();
    return bp::object(bp::handle<>(r));
}

std::vector<int> toIntList(const bp::object& o)
{
    std::vector<int> out;
    const long n = bp::len(o);
    out.reserve(n);
    for (long i = 0; i < n; ++i) out.push_back(bp::extract<int>(o[i]));
    return out;
}

/// The name of an array's dtype, for an error (str(dtype) runs numpy's Python code: not on the
/// way of a valid array).
std::string dtypeName(const np::ndarray& a) { return bp::extract<std::string>(bp::str(a.get_dtype()))(); }

/// Reads a float64 numpy array into a flat row-major vector after checking its shape.
std::vector<double> readArray(const np::ndarray& a, long rows, int cols, const char* what)
{
    if (!(a.get_dtype() == np::dtype::get_builtin<double>()))
        require(false, std::string(what) + " dtype", dtypeName(a), "float64");
    const int nd = a.get_nd();
    const long r = a.shape(0);
    const long c = nd > 1 ? a.shape(1) : 1;
    require(r == rows && c == cols, std::string(what) + " shape rows x cols", std::to_string(r) + " x " + std::to_string(c),
            std::to_string(rows) + " x " + std::to_string(cols));
    std::vector<double> out(rows * cols);
    const char* base = a.get_data();
    const Py_intptr_t* st = a.get_strides();
    for (long i = 0; i < rows; ++i)
        for (int j = 0; j < cols; ++j)
            out[i * cols + j] = *reinterpret_cast<const double*>(base + i * st[0] + (nd > 1 ? j * st[1] : 0));
    return out;
}

np::ndarray zeros(long rows, int cols, int cols2 = 0)
{
    bp::tuple shape = cols2 ? bp::make_tuple(rows, cols, cols2) : (cols ? bp::make_tuple(rows, cols) : bp::make_tuple(rows));
    return np::zeros(shape, np::dtype::get_builtin<double>());
}

/// Index of the registered law called `split`; ValueError naming the allowed names otherwise.
int lawId(const std::string& split)
{
    const int id = lawIndex(split);
    if (id < 0) {
        std::string names;
        for (const auto& n : lawNames()) names += (names.empty() ? "'" : ", '") + n + "'";
        require(false, "split", "'" + split + "'", names);
    }
    return id;
}

/// Releases the GIL while the core computes, so YADE's other threads keep running.
struct NoGil {
    PyThreadState* state = PyEval_SaveThread();
    ~NoGil() { PyEval_RestoreThread(state); }
};

/// The process's CPU time spent inside solvers' steps, for benchmarks that compare it with the
/// whole run's (bench/bench_yade_side.py: what the YADE side adds per iteration). Off unless a
/// benchmark turns it on (timeSteps): then each step reads the process's CPU clock, the clock
/// Python's time.process_time reads, before and after (two calls of about 0.3 us). Kept here
/// rather than timed from Python: a Python wrapper around the solver's step ran cold after each
/// step and counted its own cost on the YADE side (doc/performance.md, "Session 34").
struct StepClock {
    bool on = false;
    double seconds = 0;
    static double now()
    {
        timespec t;
        clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
        return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
    }
};
StepClock stepClock;

/// YADE steps O.run in a thread of its own (a new one for each O.run) that Python does not know:
/// every PyRunner call, which is every one of our engines, makes a Python thread state for it
/// (PyGILState_Ensure) and deletes it again (PyGILState_Release), mapping and unmapping a 16 KiB
/// frame stack each time. That costs about 20 us per call in an empty scene and 0.1-0.2 ms after
/// a large step, whose work has left the state's memory out of the caches (doc/performance.md,
/// "Session 25"). keepThreadState() holds one more count on that state, so that it lives as long
/// as the thread, and gives the count back when the thread ends.
///
/// It holds only a state whose count is 1 and that is not the main thread's. A call that holds a
/// state of its own around PyRunner (O.step() from a Python thread) has a count of 2 and is left
/// alone. A thread that Python started and that calls it directly is held too: Python deletes
/// that thread's state when the thread ends, whatever its count, and the destructor then finds
/// no state and does nothing. The destructor also does nothing while the interpreter finalises.
struct ThreadStateHold {
    bool held = false;
    ~ThreadStateHold()
    {
        if (!held || !Py_IsInitialized() || _Py_IsFinalizing() || PyGILState_GetThisThreadState() == nullptr) return;
        const PyGILState_STATE s = PyGILState_Ensure();
        PyGILState_Release(PyGILState_LOCKED);  // the held count
        PyGILState_Release(s);                  // the last count: deletes the state and releases the lock
    }
};
thread_local ThreadStateHold threadStateHold;

bool keepThreadState()
{
    if (threadStateHold.held) return true;
#if PY_VERSION_HEX < 0x030D0000
    PyThreadState* t = PyThreadState_Get();
    if (_PyOS_IsMainThread() || t != PyGILState_GetThisThreadState() || t->gilstate_counter != 1) return false;
    PyGILState_Ensure();  // the state is current: only its count goes up (PyGILState_LOCKED)
    threadStateHold.held = true;
    return true;
#else
    return false;  // (gilstate_counter is not in later versions' thread state; nothing held)
#endif
}

/// keepThreadState as a plain C function of no arguments: the MpmEngine calls it at every step,
/// right after the step has left the caches cold, where Boost.Python's dispatch of a call cost
/// a few microseconds (doc/performance.md, "Session 34").
PyObject* keepThreadStateCall(PyObject*, PyObject*) { return PyBool_FromLong(keepThreadState()); }
PyMethodDef keepThreadStateMethod = {
    "keepThreadState", keepThreadStateCall, METH_NOARGS,
    "Keeps the calling thread's Python thread state until the thread ends, if the current call made it "
    "(YADE's O.run thread inside a PyRunner): later PyRunner calls in that thread do not make and delete "
    "one each. Returns whether the state is held. The MpmEngine calls it at every step."};

/// The number of Python thread states of the interpreter (the current thread's included).
int threadStates()
{
    int n = 0;
    for (PyThreadState* t = PyInterpreterState_ThreadHead(PyThreadState_Get()->interp); t; t = PyThreadState_Next(t)) ++n;
    return n;
}

template <int D> struct BindErosion {
    using Er = EigenErosion<D>;
    static std::shared_ptr<Er> make(double Gc, double alpha, double kappa)
    {
        return std::make_shared<Er>(ErosionSettings{Gc, alpha, kappa});
    }
    /// (point id, step, time) of every erosion, in the order they happened.
    static bp::list events(const Er& e)
    {
        bp::list l;
        for (const auto& ev : e.events()) l.append(bp::make_tuple(ev.point, ev.step, ev.time));
        return l;
    }
    /// The point ids of the events, in order (int64), without a tuple per event.
    static np::ndarray eventPoints(const Er& e)
    {
        const auto& ev = e.events();
        np::ndarray a = np::zeros(bp::make_tuple(static_cast<long>(ev.size())), np::dtype::get_builtin<std::int64_t>());
        auto* out = reinterpret_cast<std::int64_t*>(a.get_data());
        for (std::size_t k = 0; k < ev.size(); ++k) out[k] = ev[k].point;
        return a;
    }
    /// The times of the events, in order, s.
    static np::ndarray eventTimes(const Er& e)
    {
        const auto& ev = e.events();
        np::ndarray a = zeros(static_cast<long>(ev.size()), 0);
        auto* out = reinterpret_cast<double*>(a.get_data());
        for (std::size_t k = 0; k < ev.size(); ++k) out[k] = ev[k].time;
        return a;
    }
    static void expose(const char* name)
    {
        bp::class_<Er, std::shared_ptr<Er>, boost::noncopyable>(name, bp::no_init)
            .def("__init__", bp::make_constructor(&make, bp::default_call_policies(),
                                                  (bp::arg("Gc"), bp::arg("alpha"), bp::arg("kappa"))))
            .add_property("address", +[](const Er& e) { return reinterpret_cast<std::uintptr_t>(&e); },
                          "Identity of the C++ stage (a stage restored from a saved state has a new "
                          "Python wrapper at each access, so compare addresses, not with `is`).")
            .add_property("Gc", +[](const Er& e) { return e.settings().Gc; })
            .add_property("alpha", +[](const Er& e) { return e.settings().alpha; })
            .add_property("kappa", +[](const Er& e) { return e.settings().kappa; })
            .add_property("dissipatedEnergy", &Er::dissipatedEnergy)
            .add_property("erodedCount", &Er::erodedCount)
            .add_property("searchedLastStep", &Er::searchedLastStep)
            .add_property("candidatesLastStep", &Er::candidatesLastStep)
            .def("events", &events)
            .def("eventPoints", &eventPoints, "The point of each event, in order (int64 array).")
            .def("eventTimes", &eventTimes, "The time of each event, in order (float64 array, s).");
    }
};

/// The crack diagnostics' searches (CrackFront.hpp) on numpy arrays of rows of 3 numbers.
struct BindCrackFront {
    static long rowsOf(const np::ndarray& a, const char* what)
    {
        require(a.get_nd() == 2 && a.shape(1) == 3, std::string(what) + " shape", bp::extract<std::string>(bp::str(bp::object(a).attr("shape")))(),
                "(n, 3)");
        return a.shape(0);
    }
    static np::ndarray mask(const std::vector<char>& m)
    {
        np::ndarray a = np::zeros(bp::make_tuple(static_cast<long>(m.size())), np::dtype::get_builtin<bool>());
        auto* out = reinterpret_cast<bool*>(a.get_data());
        for (std::size_t k = 0; k < m.size(); ++k) out[k] = m[k] != 0;
        return a;
    }
    /// Which points x form the main crack (crackfront::mainCrack), their positions and their
    /// squared distances from the origin: (mask, x[mask], r), r as numpy's
    /// np.sum((x[mask] - origin) ** 2, axis=1) gives it.
    static bp::tuple mainCrack(const np::ndarray& x, bp::object origin, double R)
    {
        require(std::isfinite(R) && R > 0, "R (cell size, m)", R, "R > 0");
        const long n = rowsOf(x, "x");
        const std::vector<double> xs = readArray(x, n, 3, "x");
        const Eigen::Vector3d o = toVec3(origin, "origin");
        std::vector<double> squared;
        const std::vector<char> m = crackfront::mainCrack(xs.data(), n, o.data(), R, &squared);
        long k = 0;
        for (char c : m) k += c != 0;
        np::ndarray xm = zeros(k, 3), r = zeros(k, 0);
        auto* px = reinterpret_cast<double*>(xm.get_data());
        auto* pr = reinterpret_cast<double*>(r.get_data());
        for (long i = 0, j = 0; i < n; ++i)
            if (m[i]) {
                for (int d = 0; d < 3; ++d) px[3 * j + d] = xs[3 * i + d];
                pr[j++] = squared[i];
            }
        return bp::make_tuple(mask(m), xm, r);
    }
    static np::ndarray fartherWithin(const np::ndarray& xm, const np::ndarray& r, const np::ndarray& xr,
                                     const np::ndarray& rr, double R, double R2)
    {
        require(std::isfinite(R) && R > 0 && R2 >= 0 && R2 <= R * R * (1 + 1e-12), "R2 (squared radius, m2)", R2,
                "0 <= R2 <= R^2");
        const long nm = rowsOf(xm, "xm"), nr = rowsOf(xr, "xr");
        const std::vector<double> a = readArray(xm, nm, 3, "xm"), ra = readArray(r, nm, 1, "r");
        const std::vector<double> b = readArray(xr, nr, 3, "xr"), rb = readArray(rr, nr, 1, "rr");
        return mask(crackfront::fartherWithin(a.data(), ra.data(), nm, b.data(), rb.data(), nr, R, R2));
    }
    /// The rows `rows` of x (rows of 3) as a list of 3-lists of floats.
    static bp::list rowLists(const double* x, const std::vector<long>& rows)
    {
        bp::list out;
        for (const long i : rows) {
            bp::list row;
            for (int d = 0; d < 3; ++d) row.append(x[3 * i + d]);
            out.append(row);
        }
        return out;
    }
    static bp::object mergedTips(const np::ndarray& xr, const np::ndarray& rr, const np::ndarray& farther, double R2)
    {
        const long nr = rowsOf(xr, "xr");
        const std::vector<double> b = readArray(xr, nr, 3, "xr"), rb = readArray(rr, nr, 1, "rr");
        require(farther.get_nd() == 1 && farther.shape(0) == nr, "farther (length)", farther.shape(0),
                "one flag per row of xr");
        std::vector<char> f(nr);
        for (long i = 0; i < nr; ++i) f[i] = bp::extract<bool>(farther[i]);
        std::vector<long> rows;
        if (!crackfront::mergedTips(b.data(), rb.data(), f, nr, R2, rows)) return bp::object();
        return rowLists(b.data(), rows);
    }
    static void expose()
    {
        bp::def("crackMergedTips", &mergedTips, (bp::arg("xr"), bp::arg("rr"), bp::arg("farther"), bp::arg("R2")),
                "The tips among the recent points xr (n x 3; rr their squared distances from the origin; "
                "farther: whether each has a farther neighbour): the rows without one, from the farthest (at "
                "equal distances the first row first), each kept unless a kept one lies within squared distance "
                "R2, as 3-lists, as EigenErosion._mergedTips; None when a distance is NaN.");
        bp::def("crackMain", &mainCrack, (bp::arg("x"), bp::arg("origin"), bp::arg("R")),
                "Which points x (n x 3) belong to the crack grown from origin: those whose cells of size R "
                "(floor(x / R)) connect, through cells sharing a face, an edge or a corner, to the cell of the "
                "point nearest origin. Returns (mask, x[mask], r): a bool array, the main crack's rows of x and "
                "their squared distances from origin, summed over the axes in order as numpy's row sums.");
        bp::def("crackFartherWithin", &fartherWithin,
                (bp::arg("xm"), bp::arg("r"), bp::arg("xr"), bp::arg("rr"), bp::arg("R"), bp::arg("R2")),
                "For each row i of xr (n x 3): whether a row j of xm lies within squared distance R2 of it "
                "with r[j] > rr[i] (r, rr: squared distances from the origin); R >= sqrt(R2) (a bool array).");
    }
};

Eigen::Matrix3d toMat3(const bp::object& o, const char* what)
{
    require(bp::len(o) == 3, std::string(what) + " (rows)", bp::len(o), "3 rows of 3");
    Eigen::Matrix3d m;
    for (int i = 0; i < 3; ++i) m.row(i) = toVec3(o[i], what).transpose();
    return m;
}

/// The Python objects of the YADE spheres that Contact.addFreeSpheres reads at every step (each
/// sphere's Body, State and Shape, and its flags), kept from one step to the next so that the
/// step reads only what changes (its position and radius, and for a sphere that touches a point
/// its velocity and mass), not the three objects and the flags again (doc/contact.md "Session
/// 35"). An entry is used only while it provably stands for the scene's body:
/// - it is cached only if YADE hands back the same Python objects on every read (O.bodies[id],
///   body.state and body.shape), as it does for objects made in Python (the body container's
///   shared pointer then holds a reference to the Python object); objects made in C++ come back
///   as new wrappers and are read at every step;
/// - the reference count of each of the three objects is what it was when cached: the body
///   container holds one reference to a body, a body one to its state and one to its shape, so
///   a body erased or replaced (from Python or from C++), or a state or shape replaced, changes
///   it; so does any other holder that comes or goes, which costs only a fresh read;
/// - the count of Python calls that change O.bodies (eigenmpm.contact's watch of
///   O.bodies.erase, replace, ..., of the setters of Body.state, Body.shape, Body.dynamic and
///   State.blockedDOFs) is the one the entries were cached at, which also covers an erased body
///   whose Python object someone took up at the same time.
/// An entry also keeps the sphere's flags (Entry::flags): whether it is a clump member, dynamic,
/// blocked. YADE's C++ engines do not change them during a run (doc/contact.md, "Session 35").
struct BodyCache {
    struct Entry {
        long id = -1;
        bool cacheable = false;
        bp::object body, state, shape;
        Py_ssize_t refs[3] = {-1, -1, -1};  ///< -1: to be taken once the call's own references are gone
        /// Whether the body is a clump member, is not dynamic, has blocked DOFs (bits 1, 2, 4), read
        /// once while the entry stands (they change through the counted Python paths: clump
        /// methods of O.bodies, the setters of Body.dynamic and State.blockedDOFs); -1: not read.
        int flags = -1;
        bool holds(long i) const
        {
            return cacheable && id == i && refs[0] == Py_REFCNT(body.ptr()) && refs[1] == Py_REFCNT(state.ptr()) &&
                   refs[2] == Py_REFCNT(shape.ptr());
        }
    };
    std::vector<Entry> entries;  ///< by position in the list of ids read
    long version = -1;           ///< the count of O.bodies changes they were cached at

    /// The entry of position k if it holds body `id`'s objects; null otherwise. Clears all on a
    /// new version or a list of another length.
    Entry* find(std::size_t n, long v, std::size_t k, long id)
    {
        if (v != version || entries.size() != n) {
            entries.clear();
            entries.resize(n);
            version = v;
        }
        Entry& e = entries[k];
        return e.holds(id) ? &e : nullptr;
    }
    /// Caches the objects just read for position k (the body `b` of id `idObject` in `bodies`) if
    /// YADE hands back the same objects on a second read (returns the entry; null otherwise);
    /// their counts are taken by settle().
    Entry* store(std::size_t k, long id, const bp::object& bodies, const bp::object& idObject, const bp::object& b,
                 const bp::object& st, const bp::object& sh, PyObject* kState, PyObject* kShape)
    {
        Entry& e = entries[k];
        if (e.id == id && !e.cacheable) return nullptr;  // (checked before: new wrappers at each read)
        e = Entry();
        e.id = id;
        PyObject* again = PyObject_GetItem(bodies.ptr(), idObject.ptr());
        if (!again) bp::throw_error_already_set();
        const bp::object b2{bp::handle<>(again)};
        e.cacheable = b2.ptr() == b.ptr() && attr(b, kState).ptr() == st.ptr() && attr(b, kShape).ptr() == sh.ptr();
        if (!e.cacheable) return nullptr;
        e.body = b;
        e.state = st;
        e.shape = sh;
        return &e;
    }
    /// How far ahead prefetch() asks for an entry's objects: after a step they lie beyond the
    /// caches, and each sphere's reads, one after the other, wait for them.
    static constexpr long ahead = 6;
    /// Asks the processor for the objects of position k (the id in `ids`, a list, and the
    /// entry's Body, State and Shape), if the entries are those of a list of n ids.
    void prefetch(PyObject* ids, std::size_t n, long k) const
    {
        if (k >= static_cast<long>(n) || entries.size() != n) return;
        if (PyList_CheckExact(ids)) __builtin_prefetch(PyList_GET_ITEM(ids, k));
        const Entry& e = entries[k];
        if (!e.cacheable) return;
        __builtin_prefetch(e.body.ptr());
        __builtin_prefetch(e.state.ptr());
        __builtin_prefetch(e.shape.ptr());
    }
    /// Takes the reference counts of the entries cached in this call, once its own references
    /// to them are gone.
    void settle()
    {
        for (Entry& e : entries)
            if (e.cacheable && e.refs[0] < 0) {
                e.refs[0] = Py_REFCNT(e.body.ptr());
                e.refs[1] = Py_REFCNT(e.state.ptr());
                e.refs[2] = Py_REFCNT(e.shape.ptr());
            }
    }
    static void expose()
    {
        bp::class_<BodyCache, std::shared_ptr<BodyCache>, boost::noncopyable>(
            "BodyCache", "The YADE spheres' Python objects that Contact.addFreeSpheres keeps between steps.")
            .add_property("cached", +[](const BodyCache& c) {
                int n = 0;
                for (const Entry& e : c.entries) n += e.cacheable && e.refs[0] >= 0;
                return n;
            }, "how many spheres' objects are held");
    }
};

/// The contact stage (BodyContact.hpp). The Python engine (eigenmpm.contact) refills its bodies
/// and shapes from YADE before each step and reads the forces back after it.
template <int D> struct BindContact {
    using C = BodyContact<D>;
    static std::shared_ptr<C> make(double friction)
    {
        require(std::isfinite(friction) && friction >= 0, "friction", friction, "0 <= friction < inf");
        auto c = std::make_shared<C>();
        c->friction = friction;
        return c;
    }
    static void clear(C& c)
    {
        c.shapes.clear();
        c.bodies.clear();
    }
    static int addBody(C& c, bp::object centre, bp::object velocity, bp::object angularVelocity,
                       bp::object invMass, bp::object invInertia, int id)
    {
        RigidBody b;
        b.id = id;
        b.centre = toVec3(centre, "body centre");
        b.velocity = toVec3(velocity, "body velocity");
        b.angularVelocity = toVec3(angularVelocity, "body angular velocity");
        b.invMass = toVec3(invMass, "body inverse mass");
        b.invInertia = toMat3(invInertia, "body inverse inertia");
        c.bodies.push_back(b);
        return static_cast<int>(c.bodies.size()) - 1;
    }
    /// The points, grid and support half-width of `solver` (a Solver of dimension D, once it has
    /// stepped: its grid and half-width are set then); false for anything else, None included.
    static bool pointsOf(const bp::object& solver, const MaterialPoints<D>*& points, const Grid<D>*& grid,
                         double& reach)
    {
        bool found = false;
#define EMP_POINTS_OF(D2, K)                                                              \
        if constexpr (D2 == D) {                                                          \
            bp::extract<const Solver<D2, K>&> s(solver);                                  \
            if (!found && s.check() && s().initialized()) {                               \
                points = &s().points();                                                   \
                grid = &s().grid();                                                       \
                reach = s().halfWidth() * s().settings().h; /* the support's half-width */ \
                found = true;                                                             \
            }                                                                             \
        }
        EMP_SOLVER_CONFIGURATIONS(EMP_POINTS_OF)
#undef EMP_POINTS_OF
        return found;
    }
    /// The common case in bulk: the free spheres among `ids` (YADE ids of sphere bodies that are
    /// no clump members) are read from YADE in C++ and added as a body and a sphere each, with
    /// the velocity they would have at the middle of the step without this contact (the
    /// leapfrog's v^{n+1/2}: velocity plus dt times the forces already in `forces` (O.forces) and
    /// `gravity`), in the arithmetic of the Python path it replaces (BodyContact._addBody).
    /// Given the `solver` the stage acts in, only the spheres that touch one of its points (the
    /// points do not move before the contact stage; BodyContact::touching) are read further and
    /// added: the others would receive no impulse, and their velocity, mass, inertia and forces
    /// cost 9 of the 14 calls of YADE's Python API per sphere. Without friction a sphere centred
    /// in the model (z = 0 in 2D) is central (RigidBody::central): its angular velocity, inertia
    /// and torque are not read, and no moment is written back (applyForces), 4 calls fewer each.
    /// With a BodyCache (`cache`, and `version`, the count of O.bodies changes made from Python)
    /// each sphere's Body, State and Shape objects are kept between calls (BodyCache). With
    /// readForces false the forces and moments in `forces` are known to be zero (nothing added
    /// any since YADE's ForceResetter, BodyContact._forcesBefore) and are not read.
    /// Returns (ids added, in core order; ids left for the general path: clump members, fixed or
    /// blocked bodies, anisotropic inertia where it matters). An erased body (None) is skipped.
    static bp::tuple addFreeSpheres(C& c, bp::object bodies, bp::object ids, bp::object forces, bp::object gravity,
                                    double dt, bp::object solver, bp::object cacheObject, long version,
                                    bool readForces)
    {
        static PyObject* const kState = PyUnicode_InternFromString("state");
        static PyObject* const kShape = PyUnicode_InternFromString("shape");
        static PyObject* const kRadius = PyUnicode_InternFromString("radius");
        static PyObject* const kDynamic = PyUnicode_InternFromString("dynamic");
        static PyObject* const kMember = PyUnicode_InternFromString("isClumpMember");
        static PyObject* const kMass = PyUnicode_InternFromString("mass");
        static PyObject* const kInertia = PyUnicode_InternFromString("inertia");
        static PyObject* const kBlocked = PyUnicode_InternFromString("blockedDOFs");
        static PyObject* const kPos = PyUnicode_InternFromString("pos");
        static PyObject* const kVel = PyUnicode_InternFromString("vel");
        static PyObject* const kAngVel = PyUnicode_InternFromString("angVel");
        const Eigen::Vector3d g = fastVec3(gravity, "gravity");
        const bp::object forceOf = forces.attr("f"), torqueOf = forces.attr("t");
        BodyCache* cache = cacheObject.is_none() ? nullptr : &bp::extract<BodyCache&>(cacheObject)();
        // 1. Where each sphere is, and its radius.
        struct Read {
            bp::object id, body, state;
            int sphere;  ///< index in `spheres`; -1: its shape has no radius (changed since the selection)
            BodyCache::Entry* entry;  ///< its cached objects, or null
        };
        std::vector<Read> read;
        std::vector<RigidShape> spheres;
        const long n = bp::len(ids);
        read.reserve(n);
        spheres.reserve(n);
        for (long k = 0; k < n; ++k) {
            if (cache) cache->prefetch(ids.ptr(), n, k + BodyCache::ahead);
            const bp::object id(bp::handle<>(PySequence_GetItem(ids.ptr(), k)));
            const long idValue = cache ? bp::extract<long>(id)() : -1;
            BodyCache::Entry* e = cache ? cache->find(n, version, k, idValue) : nullptr;
            bp::object b, shape;
            if (e) {
                b = e->body;
                shape = e->shape;
            } else {
                PyObject* item = PyObject_GetItem(bodies.ptr(), id.ptr());
                if (!item) bp::throw_error_already_set();
                b = bp::object(bp::handle<>(item));
                if (b.is_none()) continue;
                shape = attr(b, kShape);
            }
            PyObject* radius = PyObject_GetAttr(shape.ptr(), kRadius);
            if (!radius) {
                if (!PyErr_ExceptionMatches(PyExc_AttributeError)) bp::throw_error_already_set();
                PyErr_Clear();
                read.push_back(Read{id, b, bp::object(), -1, nullptr});
                continue;
            }
            RigidShape sh;
            sh.kind = RigidShape::sphere;
            sh.radius = bp::extract<double>(bp::object(bp::handle<>(radius)));
            const bp::object st = e ? e->state : attr(b, kState);
            if (cache && !e) e = cache->store(k, idValue, bodies, id, b, st, shape, kState, kShape);
            sh.a = fastVec3(attr(st, kPos), "position");
            read.push_back(Read{id, b, st, static_cast<int>(spheres.size()), e});
            spheres.push_back(sh);
        }
        // 2. Which of them touch a point (all of them without a solver that has stepped).
        std::vector<char> touched(spheres.size(), 1);
        const MaterialPoints<D>* points = nullptr;
        const Grid<D>* grid = nullptr;
        double reach = 0;
        if (pointsOf(solver, points, grid, reach)) c.touching(*grid, *points, reach, spheres, touched);
        // 3. Those as bodies: the free ones here, the others by the general path.
        bp::list added, rest;
        for (const auto& [id, b, st, k, e] : read) {
            if (k < 0) {
                rest.append(id);
                continue;
            }
            if (!touched[k]) continue;
            const double m = bp::extract<double>(attr(st, kMass));
            const bool central = c.friction == 0 && (D == 3 || spheres[k].a[2] == 0);
            const Eigen::Vector3d I = central ? Eigen::Vector3d::Ones() : fastVec3(attr(st, kInertia), "inertia");
            int flags = e ? e->flags : -1;
            if (flags < 0) {
                flags = (bp::extract<bool>(attr(b, kMember))() ? 1 : 0) | (bp::extract<bool>(attr(b, kDynamic))() ? 0 : 2) |
                        (bp::len(attr(st, kBlocked)) != 0 ? 4 : 0);
                if (e) e->flags = flags;
            }
            if (flags != 0 || !(m > 0) || !(I[0] == I[1] && I[1] == I[2] && I[0] > 0)) {
                rest.append(id);
                continue;
            }
            RigidBody r;
            r.id = bp::extract<int>(id);
            r.centre = spheres[k].a;
            const Eigen::Vector3d f = readForces ? fastVec3(callOne(forceOf, id), "force") : Eigen::Vector3d::Zero();
            r.velocity = fastVec3(attr(st, kVel), "velocity") + (f / m + g) * dt;
            r.invMass = Eigen::Vector3d::Constant(1.0 / m);
            r.central = central;
            if (!central) {
                const double i = 1.0 / I[0];
                const Eigen::Vector3d t =
                    readForces ? fastVec3(callOne(torqueOf, id), "torque") : Eigen::Vector3d::Zero();
                r.angularVelocity = fastVec3(attr(st, kAngVel), "angular velocity") + t * (dt * i);
                r.invInertia = Eigen::Vector3d::Constant(i).asDiagonal();
            }
            c.bodies.push_back(r);
            RigidShape sh = spheres[k];
            sh.body = static_cast<int>(c.bodies.size()) - 1;
            c.shapes.push_back(sh);
            added.append(id);
        }
        read.clear();
        if (cache) cache->settle();
        return bp::make_tuple(added, rest);
    }
    /// Adds the last step's force and moment of each body with a YADE id to `forces` (O.forces),
    /// skipping bodies on which both are zero, and the moment of a central body (none).
    static void applyForces(const C& c, bp::object forces)
    {
        const bp::object addF = forces.attr("addF"), addT = forces.attr("addT");
        // YADE's Vector3 when its converter is registered (inside YADE), a tuple otherwise.
        const bp::converter::registration* reg = bp::converter::registry::query(bp::type_id<Eigen::Vector3d>());
        const bool vector3 = reg && reg->m_to_python;
        auto out = [&](const Eigen::Vector3d& v) { return vector3 ? bp::object(v) : bp::object(fromVec3(v)); };
        for (const RigidBody& b : c.bodies) {
            if (b.id < 0 || (b.force.isZero(0) && b.torque.isZero(0))) continue;
            addF(b.id, out(b.force));
            if (!b.central) addT(b.id, out(b.torque));
        }
    }
    static RigidShape shape(C& c, int body, int kind)
    {
        require(body >= 0 && body < static_cast<int>(c.bodies.size()), "body index", body, "an added body");
        RigidShape s;
        s.body = body;
        s.kind = kind;
        return s;
    }
    static void addSphere(C& c, int body, bp::object centre, double radius)
    {
        RigidShape s = shape(c, body, RigidShape::sphere);
        s.a = toVec3(centre, "sphere centre");
        s.radius = radius;
        c.shapes.push_back(s);
    }
    static void addWall(C& c, int body, bp::object point, bp::object normal, bool twoSided)
    {
        RigidShape s = shape(c, body, RigidShape::wall);
        s.a = toVec3(point, "wall point");
        s.b = toVec3(normal, "wall normal").normalized();
        s.twoSided = twoSided;
        c.shapes.push_back(s);
    }
    static void addFacet(C& c, int body, bp::object a, bp::object b, bp::object v)
    {
        RigidShape s = shape(c, body, RigidShape::facet);
        s.a = toVec3(a, "facet vertex");
        s.b = toVec3(b, "facet vertex");
        s.c = toVec3(v, "facet vertex");
        c.shapes.push_back(s);
    }
    static void addBox(C& c, int body, bp::object centre, bp::object halfExtents, bp::object rotation)
    {
        RigidShape s = shape(c, body, RigidShape::box);
        s.a = toVec3(centre, "box centre");
        s.b = toVec3(halfExtents, "box half extents");
        s.rotation = toMat3(rotation, "box rotation");
        c.shapes.push_back(s);
    }
    static bp::tuple force(const C& c, int i)
    {
        require(i >= 0 && i < static_cast<int>(c.bodies.size()), "body index", i, "an added body");
        return fromVec3(c.bodies[i].force);
    }
    static bp::tuple torque(const C& c, int i)
    {
        require(i >= 0 && i < static_cast<int>(c.bodies.size()), "body index", i, "an added body");
        return fromVec3(c.bodies[i].torque);
    }
    static void expose(const char* name)
    {
        bp::class_<C, std::shared_ptr<C>, boost::noncopyable>(name, bp::no_init)
            .def("__init__", bp::make_constructor(&make, bp::default_call_policies(), (bp::arg("friction"))))
            .add_property("friction", +[](const C& c) { return c.friction; })
            .add_property("work", +[](const C& c) { return c.work; }, "work of the contact forces on the points in the last step, J")
            .add_property("pointsInContact", +[](const C& c) { return c.pointsInContact; })
            .add_property("nodesInContact", +[](const C& c) { return c.nodesInContact; })
            .add_property("numBodies", +[](const C& c) { return static_cast<int>(c.bodies.size()); })
            .add_property("numShapes", +[](const C& c) { return static_cast<int>(c.shapes.size()); })
            .add_property("address", +[](const C& c) { return reinterpret_cast<std::uintptr_t>(&c); })
            .def("clear", &clear)
            .def("addBody", &addBody, (bp::arg("centre"), bp::arg("velocity"), bp::arg("angularVelocity"),
                                       bp::arg("invMass"), bp::arg("invInertia"), bp::arg("id") = -1))
            .def("addFreeSpheres", &addFreeSpheres, (bp::arg("bodies"), bp::arg("ids"), bp::arg("forces"),
                                                     bp::arg("gravity"), bp::arg("dt"), bp::arg("solver") = bp::object(),
                                                     bp::arg("cache") = bp::object(), bp::arg("version") = 0,
                                                     bp::arg("readForces") = true))
            .def("applyForces", &applyForces, (bp::arg("forces")))
            .def("addSphere", &addSphere, (bp::arg("body"), bp::arg("centre"), bp::arg("radius")))
            .def("addWall", &addWall, (bp::arg("body"), bp::arg("point"), bp::arg("normal"), bp::arg("twoSided")))
            .def("addFacet", &addFacet, (bp::arg("body"), bp::arg("a"), bp::arg("b"), bp::arg("c")))
            .def("addBox", &addBox, (bp::arg("body"), bp::arg("centre"), bp::arg("halfExtents"), bp::arg("rotation")))
            .add_property("totalForce", +[](const C& c) {
                Eigen::Vector3d f = Eigen::Vector3d::Zero();
                for (const RigidBody& b : c.bodies) f += b.force;
                return fromVec3(f);
            }, "sum of the forces of the points on the bodies in the last step, N")
            .def("force", &force, "force of the points on body i in the last step, N")
            .def("torque", &torque, "its moment about the body's centre, N m");
    }
};

template <class Sv> struct Bind {
    static constexpr int D = Sv::dim;

    static std::shared_ptr<Sv> make(double h, int ppc, double massCutoff, int padding, bp::object gravity,
                                    const std::string& transfer, const std::string& stressUpdate, int columnCells)
    {
        SolverSettings s;
        s.transfer = transferOf(transfer);
        s.stressUpdate = stressUpdateOf(stressUpdate);
        require(s.transfer != Transfer::unset, "transfer", transfer, "'FLIP' or 'APIC'");
        require(s.stressUpdate != StressUpdate::unset, "stressUpdate", stressUpdate, "'smallStrain' or 'corotational'");
        s.h = h;
        s.ppc = ppc;
        s.massCutoff = massCutoff;
        s.padding = padding;
        s.columnCells = columnCells;
        s.gravity = toVec3(gravity, "gravity");
        return std::make_shared<Sv>(s);
    }
    /// Appends the points; returns the id of the first. With total >= 0 (a run distributed at
    /// set-up, Solver::holdPoints) they are this rank's share, from `offset` on, of `total`
    /// points added to the whole scene.
    static int addPoints(Sv& s, np::ndarray pos, np::ndarray vel, np::ndarray vol, int material, int offset, int total)
    {
        const long n = pos.shape(0);
        const auto x = readArray(pos, n, 3, "positions");
        const auto v = readArray(vel, n, 3, "velocities");
        const auto V = readArray(vol, n, 1, "volumes");
        if (total >= 0) s.holdPoints(offset, static_cast<int>(n), total);
        const int first = total >= 0 ? s.numGlobalPoints() - total + offset : static_cast<int>(s.points().size());
        s.reservePoints(static_cast<std::size_t>(n));
        for (long i = 0; i < n; ++i)
            s.addPoint(Eigen::Vector3d(x[3 * i], x[3 * i + 1], x[3 * i + 2]),
                       Eigen::Vector3d(v[3 * i], v[3 * i + 1], v[3 * i + 2]), V[i], material);
        return first;
    }
    static void step(Sv& s, double dt, int nThreads)
    {
        NoGil nogil;
        if (!stepClock.on) return s.step(dt, nThreads);
        const double t0 = StepClock::now();
        try {
            s.step(dt, nThreads);
        } catch (...) {
            stepClock.seconds += StepClock::now() - t0;
            throw;
        }
        stepClock.seconds += StepClock::now() - t0;
    }
    /// time = t, then step(dt, nThreads): the MpmEngine's step in one call (each call through
    /// Boost.Python costs microseconds right after a step, doc/performance.md "Session 34").
    static void stepAt(Sv& s, double t, double dt, int nThreads)
    {
        s.setTime(t);
        step(s, dt, nThreads);
    }
    static void setDomain(Sv& s, bp::object lo, bp::object hi) { s.setDomain(toVec3(lo, "domain lo"), toVec3(hi, "domain hi")); }
    static void setGravity(Sv& s, bp::object g) { s.setGravity(toVec3(g, "gravity")); }
    static int addVelocityCondition(Sv& s, bp::object nodes, bp::object points, unsigned mask, bp::object vel, double ramp)
    {
        return s.addVelocityCondition(toIntList(nodes), toIntList(points), mask, toVec3(vel, "velocity"), ramp);
    }
    static void setConditionVelocity(Sv& s, int id, bp::object vel, double ramp) { s.setConditionVelocity(id, toVec3(vel, "velocity"), ramp); }
    static int addTraction(Sv& s, bp::object points, bp::object t, double ramp, double layer)
    {
        return s.addTraction(toIntList(points), toVec3(t, "traction"), ramp, layer);
    }
    static bp::tuple reaction(const Sv& s, int id) { return fromVec3(s.reaction(id)); }
    static bp::tuple gravity(const Sv& s) { return fromVec3(s.settings().gravity); }

    template <class Get> static np::ndarray vectors(const Sv& s, Get get)
    {
        const long n = s.points().size();
        np::ndarray a = zeros(n, 3);
        double* out = reinterpret_cast<double*>(a.get_data());
        for (long p = 0; p < n; ++p)
            for (int d = 0; d < D; ++d) out[3 * p + d] = get(p)[d];
        return a;
    }
    static np::ndarray positions(const Sv& s) { return vectors(s, [&](long p) { return s.points().x[p]; }); }
    /// Positions of this process's points with the given indices (a 1D int64 array), one row
    /// each: the crack diagnostics read the eroded points without copying every point's position.
    static np::ndarray positionsAt(const Sv& s, const np::ndarray& indices)
    {
        if (!(indices.get_dtype() == np::dtype::get_builtin<std::int64_t>()))
            require(false, "indices dtype", dtypeName(indices), "int64");
        require(indices.get_nd() == 1, "indices dimensions", indices.get_nd(), "1");
        const long m = indices.shape(0), n = s.points().size();
        const char* base = indices.get_data();
        const Py_intptr_t stride = indices.get_strides()[0];
        np::ndarray a = zeros(m, 3);
        double* out = reinterpret_cast<double*>(a.get_data());
        for (long k = 0; k < m; ++k) {
            const std::int64_t p = *reinterpret_cast<const std::int64_t*>(base + k * stride);
            if (p < 0 || p >= n) require(false, "point index", p, "0 <= index < " + std::to_string(n));
            for (int d = 0; d < D; ++d) out[3 * k + d] = s.points().x[p][d];
        }
        return a;
    }
    /// One record of EigenErosion's crack diagnostics in a run of one process (EigenErosion.record,
    /// py/eigenmpm/fracture.py): the numbers its _crack, _frontOf and _tipsOf make with a dozen numpy
    /// steps, here in one call (a record follows a step, when the interpreter runs cold). The eroded
    /// points of `erosion`'s events, at their positions now (coordinate `axis` set to 0 when axis >= 0:
    /// throughAxis), form the main crack grown from `origin` (crackfront::mainCrack, cells of size R).
    /// Returns (front, tips, xr, rr, farther): the largest distance of a main-crack point from the
    /// origin (0 before the first event); the tips as 3-lists (crackfront::mergedTips), or None
    /// when a candidate's distance is NaN, and then (else None) the rows of the
    /// main-crack points eroded at or after `since`, their squared distances from the origin
    /// (numpy's row sums: ((d0^2 + d1^2) + d2^2)), and whether a main-crack point within squared
    /// distance R2 of each lies farther from the origin (crackfront::fartherWithin), for the
    /// Python merge. The same operations on the same numbers as the numpy steps (test_erosion.py
    /// compares the records of both bit for bit).
    static bp::tuple crackRecord(const Sv& s, const EigenErosion<D>& erosion, bp::object origin, int axis, double since,
                                 double R, double R2)
    {
        require(axis >= -1 && axis < 3, "axis", axis, "-1 (none), 0, 1 or 2");
        require(std::isfinite(R) && R > 0 && R2 >= 0 && R2 <= R * R * (1 + 1e-12), "R2 (squared radius, m2)", R2,
                "0 <= R2 <= R^2");
        const auto& ev = erosion.events();
        const long n = static_cast<long>(ev.size()), points = static_cast<long>(s.points().size());
        if (n == 0) return bp::make_tuple(0.0, bp::list(), bp::object(), bp::object(), bp::object());
        std::vector<double> x(3 * n, 0.0);
        for (long k = 0; k < n; ++k) {
            const long p = ev[k].point;
            if (p < 0 || p >= points) require(false, "eroded point index", p, "0 <= index < " + std::to_string(points));
            for (int d = 0; d < D; ++d) x[3 * k + d] = s.points().x[p][d];
            if (axis >= 0) x[3 * k + axis] = 0.0;
        }
        const Eigen::Vector3d o = toVec3(origin, "origin");
        std::vector<double> squared;
        const std::vector<char> main = crackfront::mainCrack(x.data(), n, o.data(), R, &squared);
        std::vector<double> xm, r, xr, rr;
        double largest = -std::numeric_limits<double>::infinity();
        for (long k = 0; k < n; ++k) {
            if (!main[k]) continue;
            xm.insert(xm.end(), &x[3 * k], &x[3 * k] + 3);
            r.push_back(squared[k]);
            largest = std::max(largest, squared[k]);
            if (ev[k].time >= since) {
                xr.insert(xr.end(), &x[3 * k], &x[3 * k] + 3);
                const double d0 = x[3 * k] - o[0], d1 = x[3 * k + 1] - o[1], d2 = x[3 * k + 2] - o[2];
                rr.push_back((d0 * d0 + d1 * d1) + d2 * d2);
            }
        }
        const long nm = static_cast<long>(r.size()), nr = static_cast<long>(rr.size());
        const std::vector<char> farther = crackfront::fartherWithin(xm.data(), r.data(), nm, xr.data(), rr.data(), nr, R, R2);
        std::vector<long> tipRows;
        if (crackfront::mergedTips(xr.data(), rr.data(), farther, nr, R2, tipRows))
            return bp::make_tuple(std::sqrt(largest), BindCrackFront::rowLists(xr.data(), tipRows), bp::object(),
                                  bp::object(), bp::object());
        np::ndarray axr = zeros(nr, 3), arr = zeros(nr, 0);
        std::copy(xr.begin(), xr.end(), reinterpret_cast<double*>(axr.get_data()));
        std::copy(rr.begin(), rr.end(), reinterpret_cast<double*>(arr.get_data()));
        return bp::make_tuple(std::sqrt(largest), bp::object(), axr, arr, BindCrackFront::mask(farther));
    }
    static np::ndarray velocities(const Sv& s) { return vectors(s, [&](long p) { return s.points().v[p]; }); }

    /// 3x3 tensors; in 2D the out-of-plane component follows the material's plane condition:
    /// plane strain has eps_zz = 0 and the law's sigma_zz (Law.hpp: outOfPlaneStress); plane
    /// stress has sigma_zz = 0 and eps_zz = -nu/(1-nu) (eps_xx + eps_yy).
    static np::ndarray tensors(const Sv& s, bool stress)
    {
        const auto& P = s.points();
        const long n = P.size();
        np::ndarray a = zeros(n, 3, 3);
        double* out = reinterpret_cast<double*>(a.get_data());
        for (long p = 0; p < n; ++p) {
            // t, the tensor written: the stress, or the strain (the co-rotated U - I of F = R U
            // turned to the spatial frame, R (U - I) R^T; NaN for a degenerate F). eps, the
            // strain itself, also gives a 2D point's out-of-plane component.
            Mat<D> eps, t;
            if (stress) {
                t = P.stressOf(p, s.materials(), &eps);  // (not stored; eps: the strain it used)
            } else if (!P.deformation) {
                t = eps = full(P.strain[p]);
            } else {  // (MaterialPoints::strainOf, with R kept for the spatial frame)
                Mat<D> R, U;
                const bool ok = polarDecomposition(P.deformationGradient[p], R, U);
                eps = ok ? Mat<D>(U - Mat<D>::Identity()) : Mat<D>::Constant(std::numeric_limits<double>::quiet_NaN());
                t = ok ? Mat<D>(R * eps * R.transpose()) : eps;
            }
            for (int i = 0; i < D; ++i)
                for (int j = 0; j < D; ++j) out[9 * p + 3 * i + j] = t(i, j);
            if constexpr (D == 2) {
                const ElasticMaterial& m = s.materials()[P.material[p]];
                double zz = 0;
                if (stress)
                    withLaw(m.law, [&](auto law) { zz = decltype(law)::outOfPlaneStress(eps, P.damage[p], m); });
                else if (m.planeStress)
                    zz = -m.nu / (1.0 - m.nu) * eps.trace();
                out[9 * p + 8] = zz;
            }
        }
        return a;
    }
    static np::ndarray stress(const Sv& s) { return tensors(s, true); }
    /// n x 3 x 3 array of D x D matrices per point (zero-padded).
    template <class Get> static np::ndarray matrices(const Sv& s, Get get)
    {
        const long n = s.points().size();
        np::ndarray a = zeros(n, 3, 3);
        double* out = reinterpret_cast<double*>(a.get_data());
        for (long p = 0; p < n; ++p) {
            const Mat<D> m = get(p);
            for (int i = 0; i < D; ++i)
                for (int j = 0; j < D; ++j) out[9 * p + 3 * i + j] = m(i, j);
        }
        return a;
    }
    static np::ndarray velocityGradients(const Sv& s) { return matrices(s, [&](long p) { return s.velocityGradient(p); }); }
    static np::ndarray deformationGradients(const Sv& s)
    {
        const auto& P = s.points();
        return matrices(s, [&](long p) { return P.deformation ? P.deformationGradient[p] : Mat<D>::Identity(); });
    }
    static void setVelocityGradients(Sv& s, bp::object ids, np::ndarray grads)
    {
        const auto id = toIntList(ids);
        const auto g = readArray(grads, static_cast<long>(id.size()), 9, "velocity gradients");
        for (std::size_t i = 0; i < id.size(); ++i) {
            Mat<D> C;
            for (int a = 0; a < D; ++a)
                for (int b = 0; b < D; ++b) C(a, b) = g[9 * i + 3 * a + b];
            s.setVelocityGradient(id[i], C);
        }
    }
    static np::ndarray strain(const Sv& s) { return tensors(s, false); }

    template <class T> static np::ndarray scalars(const std::vector<T>& v)
    {
        np::ndarray a = zeros(v.size(), 0);
        double* out = reinterpret_cast<double*>(a.get_data());
        for (std::size_t i = 0; i < v.size(); ++i) out[i] = static_cast<double>(v[i]);
        return a;
    }
    /// psi+ or psi- of each point: its law's at its strain (the stress update's values: not stored).
    static np::ndarray splitEnergy(const Sv& s, bool plus)
    {
        const auto& P = s.points();
        std::vector<double> e(P.size());
        for (std::size_t p = 0; p < P.size(); ++p) {
            const LawResponse<D> r = lawResponse<D>(P.strainOf(p), s.materials()[P.material[p]]);
            e[p] = plus ? r.psiPlus : r.psiMinus;
        }
        return scalars(e);
    }
    static np::ndarray psiPlus(const Sv& s) { return splitEnergy(s, true); }
    static np::ndarray psiMinus(const Sv& s) { return splitEnergy(s, false); }
    static np::ndarray history(const Sv& s) { return scalars(s.points().history); }
    static np::ndarray damage(const Sv& s) { return scalars(s.points().damage); }
    /// The points' ids in the single-process scene: 0, 1, ... unless distributed (doc/parallel.md).
    static np::ndarray globalIds(const Sv& s)
    {
        const long n = static_cast<long>(s.points().size());
        np::ndarray a = np::zeros(bp::make_tuple(n), np::dtype::get_builtin<std::int64_t>());
        auto* out = reinterpret_cast<std::int64_t*>(a.get_data());
        for (long p = 0; p < n; ++p) out[p] = s.distribution() ? s.points().globalId[p] : p;
        return a;
    }
    static np::ndarray volume(const Sv& s) { return scalars(s.points().volume); }
    static np::ndarray mass(const Sv& s) { return scalars(s.points().masses()); }
    static np::ndarray material(const Sv& s) { return scalars(s.points().material); }

    static void setVelocities(Sv& s, np::ndarray vel)
    {
        auto& P = s.points();
        const auto v = readArray(vel, P.size(), 3, "velocities");
        for (std::size_t p = 0; p < P.size(); ++p)
            for (int d = 0; d < D; ++d) {
                require(std::isfinite(v[3 * p + d]), "velocity of point " + std::to_string(p), v[3 * p + d], "finite");
                P.v[p][d] = v[3 * p + d];
            }
    }
    static np::ndarray nodePositions(Sv& s)
    {
        s.initialize();
        const auto& g = s.grid();
        const long n = g.numNodes();
        np::ndarray a = zeros(n, 3);
        double* out = reinterpret_cast<double*>(a.get_data());
        for (long I = 0; I < n; ++I) {
            const auto x = g.nodePosition(I);
            for (int d = 0; d < D; ++d) out[3 * I + d] = x[d];
        }
        return a;
    }
    static bp::tuple gridShape(Sv& s)
    {
        s.initialize();
        bp::list l;
        for (int d = 0; d < D; ++d) l.append(s.grid().n[d]);
        return bp::tuple(l);
    }
    static bp::tuple gridOrigin(Sv& s)
    {
        s.initialize();
        Eigen::Vector3d o = Eigen::Vector3d::Zero();
        o.head<D>() = s.grid().origin;
        return fromVec3(o);
    }
    static void setErosion(Sv& s, bp::object e)
    {
        if (e.is_none()) {
            s.setErosion(nullptr);
            return;
        }
        s.setErosion(bp::extract<std::shared_ptr<EigenErosion<D>>>(e)());
    }
    static void setContact(Sv& s, bp::object c)
    {
        if (c.is_none()) {
            s.setContact(nullptr);
            return;
        }
        s.setContact(bp::extract<std::shared_ptr<BodyContact<D>>>(c)());
    }
    static np::ndarray energyReleaseRate(Sv& s, bp::object ids, bool bruteForce)
    {
        require(s.erosion() != nullptr, "erosion", "none attached", "attach an EigenErosion first");
        const auto list = toIntList(ids);
        for (int p : list)
            require(p >= 0 && p < static_cast<int>(s.points().size()), "point id", p, "an existing point");
        const auto g = bruteForce ? s.erosion()->energyReleaseRateBruteForce(s.points(), list)
                                  : s.erosion()->energyReleaseRate(s.points(), list);
        return scalars(g);
    }
    static int addCrack(Sv& s, bp::object vertices)
    {
        std::vector<Eigen::Vector3d> v;
        const long n = bp::len(vertices);
        for (long i = 0; i < n; ++i) v.push_back(toVec3(vertices[i], "crack vertex"));
        return s.addCrack(v);
    }
    static bp::list crackVertices(const Sv& s, int c)
    {
        const auto& ph = s.phantomNodes();
        require(c >= 0 && c < static_cast<int>(ph.numCracks()), "crack id", c, "an existing crack");
        bp::list l;
        for (const auto& v : ph.vertices(c)) {
            Eigen::Vector3d x = Eigen::Vector3d::Zero();
            x.head<D>() = v;
            l.append(fromVec3(x));
        }
        return l;
    }
    static bp::list markedNodes(const Sv& s)
    {
        bp::list l;
        for (int I : s.phantomNodes().markedNodes()) l.append(I);
        return l;
    }
    static int addMaterial(Sv& s, double E, double nu, double rho, bool planeStress, const std::string& split)
    {
        return s.addMaterial(E, nu, rho, planeStress, lawId(split));
    }
    static bp::dict materialInfo(const Sv& s, int id)
    {
        require(id >= 0 && id < static_cast<int>(s.materials().size()), "material (id)", id, "an existing id");
        const auto& m = s.materials()[id];
        bp::dict d;
        d["E"] = m.E;
        d["nu"] = m.nu;
        d["rho"] = m.rho;
        d["planeStress"] = m.planeStress;
        d["lambda"] = m.lambda;
        d["mu"] = m.mu;
        d["waveSpeed"] = m.waveSpeed();
        d["split"] = lawNames()[m.law];
        return d;
    }

    static bp::object saveState(const Sv& s)
    {
        std::ostringstream os(std::ios::binary);
        {
            NoGil nogil;
            s.saveState(os);
        }
        const std::string b = os.str();
        return bp::object(bp::handle<>(PyBytes_FromStringAndSize(b.data(), static_cast<Py_ssize_t>(b.size()))));
    }
    static void expose(const char* name)
    {
        bp::class_<Sv, std::shared_ptr<Sv>, boost::noncopyable>(name, bp::no_init)
            .def("__init__", bp::make_constructor(&make, bp::default_call_policies(),
                                                  (bp::arg("h"), bp::arg("ppc"), bp::arg("massCutoff"),
                                                   bp::arg("padding"), bp::arg("gravity"),
                                                   bp::arg("transfer") = "FLIP", bp::arg("stressUpdate") = "smallStrain",
                                                   bp::arg("columnCells") = 0)))
            .add_property("columnCells", +[](const Sv& s) { return s.settings().columnCells; })
            .add_property("transfer", +[](const Sv& s) { return std::string(emp::name(s.settings().transfer)); })
            .add_property("stressUpdate", +[](const Sv& s) { return std::string(emp::name(s.settings().stressUpdate)); })
            .def("kineticEnergyAtStep", &Sv::kineticEnergyAtStep)
            .add_property("pipelined", &Sv::pipelined, &Sv::setPipelined,
                          "whether a step may run as a wavefront over the strips where the scene allows one "
                          "(doc/performance.md, 'Session 52'); False: pass by pass. The same results either way.")
            .def("lastStepPipelined", &Sv::lastStepPipelined)
            .def("lastStepWorkers", &Sv::lastStepWorkers)
            .def("externalWork", &Sv::externalWork)
            .def("linearMomentum", +[](const Sv& s) { return fromVec3(s.linearMomentum()); })
            .def("angularMomentum", +[](const Sv& s) { return fromVec3(s.angularMomentum()); })
            .def("diagnostics", +[](const Sv& s) {
                const auto d = s.diagnostics();
                return bp::make_tuple(d.kinetic, d.elastic, fromVec3(d.momentum), fromVec3(d.angularMomentum));
            })
            .def("velocityGradients", &velocityGradients)
            .def("deformationGradients", &deformationGradients)
            .def("setVelocityGradients", &setVelocityGradients, (bp::arg("ids"), bp::arg("gradients")))
            .add_property("dim", +[](const Sv&) { return D; })
            .add_property("time", &Sv::time, &Sv::setTime)
            .add_property("steps", &Sv::steps)
            .add_property("numPoints", +[](const Sv& s) { return static_cast<long>(s.points().size()); })
            .add_property("numNodes", +[](const Sv& s) { return s.grid().numNodes(); })
            .add_property("initialized", &Sv::initialized)
            .add_property("gravity", &gravity, &setGravity)
            .def("addMaterial", &addMaterial, (bp::arg("E"), bp::arg("nu"), bp::arg("rho"), bp::arg("planeStress"), bp::arg("split")))
            .def("materialInfo", &materialInfo)
            .def("addPoints", &addPoints, (bp::arg("positions"), bp::arg("velocities"), bp::arg("volumes"), bp::arg("material"),
                                           bp::arg("offset") = 0, bp::arg("total") = -1))
            .def("setDomain", &setDomain)
            .def("initialize", &Sv::initialize)
            .def("addVelocityCondition", &addVelocityCondition,
                 (bp::arg("nodes"), bp::arg("points"), bp::arg("mask"), bp::arg("velocity"), bp::arg("rampTime")))
            .def("setConditionVelocity", &setConditionVelocity)
            .def("addTraction", &addTraction, (bp::arg("points"), bp::arg("traction"), bp::arg("rampTime"), bp::arg("layer")))
            .def("reaction", &reaction)
            .def("criticalTimeStep", &Sv::criticalTimeStep)
            .def("step", &step, (bp::arg("dt"), bp::arg("nThreads")))
            .def("stepAt", &stepAt, (bp::arg("time"), bp::arg("dt"), bp::arg("nThreads")),
                 "Sets time, then steps: time = t; step(dt, nThreads).")
            .def("kineticEnergy", &Sv::kineticEnergy)
            .def("elasticEnergy", &Sv::elasticEnergy)
            .def("positions", &positions)
            .def("positionsAt", &positionsAt, (bp::arg("indices")))
            .def("crackRecord", &crackRecord, (bp::arg("erosion"), bp::arg("origin"), bp::arg("axis"), bp::arg("since"),
                                               bp::arg("R"), bp::arg("R2")))
            .def("velocities", &velocities)
            .def("setVelocities", &setVelocities)
            .def("stress", &stress)
            .def("strain", &strain)
            .def("psiPlus", &psiPlus)
            .def("psiMinus", &psiMinus)
            .def("history", &history)
            .def("globalIds", &globalIds)
            .def("distribute", +[](Sv& s, int rankColumns) { s.distribute(std::make_shared<emp::MpiTransport>(), rankColumns); },
                 (bp::arg("rankColumns") = 1))
            .def("distributeSetup", +[](Sv& s, int rankColumns) {
                s.distributeSetup(std::make_shared<emp::MpiTransport>(), rankColumns);
            }, (bp::arg("rankColumns") = 1))
            .add_property("rankColumns", +[](const Sv& s) { return s.distribution() ? s.distribution()->rankColumns() : 1; })
            .def("rankColumnRanges", +[](const Sv& s) {
                bp::list out;
                if (s.distribution())
                    for (int f : s.distribution()->firstColumns()) out.append(f);
                return out;
            })
            .add_property("numGlobalPoints", &Sv::numGlobalPoints)
            .def("referencePositions", +[](const Sv& s) {
                require(s.points().referenced, "referencePositions", "asked of a solver that does not carry them",
                        "a run distributed at set-up (MpmEngine(distributedSetup=True) under mpiexec)");
                return vectors(s, [&](long p) { return s.points().reference[p]; });
            })
            .add_property("rank", +[](const Sv& s) { return s.distribution() ? s.distribution()->rank() : 0; })
            .add_property("ranks", +[](const Sv& s) { return s.distribution() ? s.distribution()->size() : 1; })
            .add_property("distributedPart", &Sv::distributedPart)
            .def("setRebalance", &Sv::setRebalance, (bp::arg("tolerance"), bp::arg("period")))
            .add_property("rebalances", &Sv::rebalances)
            .add_property("imbalance", +[](const Sv& s) { return s.distribution() ? s.distribution()->imbalance() : 0.0; })
            .def("rankStrips", +[](const Sv& s) {
                bp::list out;
                if (s.distribution())
                    for (int f : s.distribution()->firstStrips()) out.append(f);
                return out;
            })
            .def("damage", &damage)
            .def("volume", &volume)
            .def("mass", &mass)
            .def("material", &material)
            .def("nodePositions", &nodePositions)
            .def("gridShape", &gridShape)
            .def("gridOrigin", &gridOrigin)
            .def("setErosion", &setErosion)
            .def("setContact", &setContact)
            .def("setCrackContact", &Sv::setCrackContact, (bp::arg("on"), bp::arg("friction")))
            .def("setPointBodies", &Sv::setPointBodies, (bp::arg("first"), bp::arg("count"), bp::arg("body")))
            .def("pointBody", +[](const Sv& s, int p) {
                require(p >= 0 && p < static_cast<int>(s.points().size()), "point", p, "a point id of this engine");
                return s.pointBody(p);
            }, (bp::arg("point")))
            .def("setBodyFriction", &Sv::setBodyFriction, (bp::arg("friction")))
            .add_property("bodyFriction", &Sv::bodyFriction)
            .add_property("bodyContactPairs", &Sv::bodyContactPairs, "field pairs of different bodies in contact after the forces in the last step")
            .add_property("crackContactPairs", +[](const Sv& s) { return s.crackContact() ? s.crackContact()->pairsInContact : 0; },
                          "(node, twin) pairs of the crack faces in contact after the forces of the last step")
            .add_property("contact", +[](const Sv& s) { return s.contact(); })
            .add_property("halfWidth", +[](const Sv& s) { return s.halfWidth() * s.settings().h; },
                          "half-width of a point's domain, m")
            .def("addCrack", &addCrack)
            .def("crackVertices", &crackVertices)
            .add_property("numCracks", +[](const Sv& s) { return static_cast<int>(s.phantomNodes().numCracks()); })
            .add_property("numTwins", +[](const Sv& s) { return s.phantomNodes().numTwins(); })
            .def("markedNodes", &markedNodes)
            .def("energyReleaseRate", &energyReleaseRate, (bp::arg("ids"), bp::arg("bruteForce")))
            .add_property("erosion", +[](const Sv& s) { return s.erosion(); })
            .def("saveState", &saveState,
                 "The solver's whole state as bytes (Solver::saveState); _eigenmpm.solverFromState restores it.");
    }
};

}  // namespace

// The module is built twice from this file: _eigenmpm for any x86-64 processor and, where the
// compiler offers it, _eigenmpm_v2 for x86-64-v2 (SSE3 to SSE4.2); eigenmpm/_isa.py imports the
// one the processor runs (doc/performance.md, "Session 17").
#ifndef EMP_MODULE_NAME
#define EMP_MODULE_NAME _eigenmpm
#endif
BOOST_PYTHON_MODULE(EMP_MODULE_NAME)
{
    np::initialize();
    bp::def("laneIsa", +[] { return std::string(name(laneIsa())); },
            "The vector width of the lane loops (pkg/Lanes.hpp): 'avx512', 'avx2' or 'baseline'.");
    bp::def("setLaneIsa", +[](const std::string& w) {
        LaneIsa isa;
        require(laneIsaOf(w, isa), "lanes", w, "'auto', 'avx512', 'avx2' or 'baseline'");
        return std::string(name(setLaneIsa(isa)));
    }, (bp::arg("width")),
            "Sets the lanes' width (capped at what the processor runs; the results are the same in every width); "
            "returns the width set.");
    bp::def("timeSteps", +[](bool on) {
        stepClock.on = on;
        stepClock.seconds = 0;
    }, (bp::arg("on")),
            "Benchmarks: from now on (on=True) or no longer, sum the process's CPU time (time.process_time's "
            "clock) spent inside every solver's step; resets the sum.");
    bp::def("stepCpuSeconds", +[] { return stepClock.seconds; },
            "The process's CPU seconds spent inside solvers' steps since timeSteps(True).");
    bp::scope().attr("keepThreadState") =
        bp::object(bp::handle<>(PyCFunction_NewEx(&keepThreadStateMethod, nullptr, nullptr)));
    bp::def("threadStates", &threadStates, "The number of Python thread states of the interpreter.");
    bp::def("lawNames", +[] {
        bp::list l;
        for (const auto& n : lawNames()) l.append(n);
        return l;
    }, "Names of the registered constitutive laws (ElasticMaterial(split=...)), in index order.");
    bp::def("initiationRatio",
            +[](int dim, double E, double nu, bool planeStress, const std::string& split, const std::string& mode,
                double offset, double mixityDeg) {
                require(dim == 2 || dim == 3, "dim", dim, "2 or 3");
                require(mode == "I" || mode == "II", "mode", mode, "'I' or 'II'");
                require(std::isfinite(offset) && offset >= 0 && offset <= 1, "offset (fraction of kappa)", offset,
                        "0 <= offset <= 1");
                require(std::isnan(mixityDeg) || std::fabs(mixityDeg) <= 90, "mixity_deg", mixityDeg,
                        "-90 <= mixity_deg <= 90, or NaN (pure mode)");
                const auto m = ElasticMaterial::make(E, nu, 1.0, planeStress, dim, lawId(split));
                const double psi = std::isnan(mixityDeg) ? (mode == "I" ? 0.0 : 0.5 * M_PI) : mixityDeg * M_PI / 180.0;
                return dim == 2 ? initiationRatioMixed<2>(m, psi, offset) : initiationRatioMixed<3>(m, psi, offset);
            },
            (bp::arg("dim"), bp::arg("E"), bp::arg("nu"), bp::arg("planeStress"), bp::arg("split"),
             bp::arg("mode") = "I", bp::arg("offset") = 0.0,
             bp::arg("mixity_deg") = std::numeric_limits<double>::quiet_NaN()),
            "kappa <psi+> / G of Eq 23 on the singular field of a sharp straight crack (doc/fracture.md): "
            "Eq 24 starts such a crack at G = Gc / (alpha ratio); alpha = 1/ratio is Griffith's. offset: "
            "where the neighbourhood is centred ahead of the tip, as a fraction of kappa. mixity_deg: a "
            "mixed field K_I = cos, K_II = sin of that angle (G = K_I^2 + K_II^2 over E'), instead of mode.");
    BindErosion<2>::expose("Erosion2");
    BindErosion<3>::expose("Erosion3");
    BindCrackFront::expose();
    BodyCache::expose();
    BindContact<2>::expose("Contact2");
    BindContact<3>::expose("Contact3");
    // One class per configuration (Configurations.hpp), named Solver<D><Kernel name>, and the
    // dict solvers[(dim, kernel name in lower case)] = class for the engines.
    bp::dict solvers;
#define EMP_EXPOSE(D, K)                                                                  \
    {                                                                                     \
        std::string name = std::string("Solver") + std::to_string(D) + K::name;           \
        name[7] = static_cast<char>(std::toupper(name[7]));                               \
        Bind<Solver<D, K>>::expose(name.c_str());                                         \
        std::string key = K::name;                                                        \
        for (auto& ch : key) ch = static_cast<char>(std::tolower(ch));                    \
        solvers[bp::make_tuple(D, key)] = bp::scope().attr(name.c_str());                 \
    }
    EMP_SOLVER_CONFIGURATIONS(EMP_EXPOSE)
#undef EMP_EXPOSE
    bp::scope().attr("solvers") = solvers;
    bp::def("solverFromState", +[](bp::object data) -> bp::object {
        char* buf = nullptr;
        Py_ssize_t len = 0;
        if (PyBytes_AsStringAndSize(data.ptr(), &buf, &len) != 0) bp::throw_error_already_set();
        const std::string bytes(buf, static_cast<std::size_t>(len));
        std::istringstream probe(bytes, std::ios::binary);
        const StateHeader h = readStateHeader(probe);
        bp::object out;
#define EMP_RESTORE(D, K)                                                       \
        if (out.is_none() && h.dim == D && h.kernel == K::name) {               \
            std::istringstream is(bytes, std::ios::binary);                     \
            std::shared_ptr<Solver<D, K>> sv;                                   \
            {                                                                   \
                NoGil nogil;                                                    \
                sv = Solver<D, K>::loadState(is);                               \
            }                                                                   \
            out = bp::object(sv);                                               \
        }
        EMP_SOLVER_CONFIGURATIONS(EMP_RESTORE)
#undef EMP_RESTORE
        if (out.is_none())
            throw SimulationError("EigenMPM: the saved state is of a " + std::to_string(h.dim) + "D " + h.kernel +
                                  " solver, which this EigenMPM is not built for");
        return out;
    }, bp::arg("state"), "The solver saved as `state` (bytes of Solver.saveState()), of its class.");
    // The shape names in the user's spelling (MpmEngine(shape=...)), each once, in list order.
    bp::list shapes;
#define EMP_SHAPE(D, K) \
    if (!shapes.contains(K::name)) shapes.append(K::name);
    EMP_SOLVER_CONFIGURATIONS(EMP_SHAPE)
#undef EMP_SHAPE
    bp::scope().attr("shapes") = shapes;
}
