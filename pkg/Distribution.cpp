#include "Distribution.hpp"

#include <cmath>
#include <limits>

#include "Scheduler.hpp"

namespace emp {

template <int D> Distribution<D>::Distribution(std::shared_ptr<Transport> t) : t_(std::move(t))
{
    require(t_ != nullptr, "transport", "null", "a Transport object");
    rank_ = t_->rank();
    size_ = t_->size();
    require(size_ >= 1, "number of ranks", size_, ">= 1");
}

template <int D> void Distribution<D>::setColumns(int columns, int columnCells, int numColumns, const std::array<int, D>& n)
{
    require(!partitioned(), "rank columns", "set after the partition", "before the first step");
    require(columns >= 1 && size_ % columns == 0, "rankColumns", columns,
            "a divisor of the number of ranks, " + std::to_string(size_));
    if (columns > 1) {
        require(columnCells > 0, "columnCells", columnCells,
                "a number of cells > 0 with rankColumns = " + std::to_string(columns) +
                    " (the ranks of a row split the Scheduler's columns)");
        require(columns <= numColumns, "rankColumns", columns,
                "at most the number of columns of " + std::to_string(columnCells) + " cells along the first axis, " +
                    std::to_string(numColumns) + " here (smaller columnCells, or fewer rank columns)");
    }
    cols_ = columns;
    columnCells_ = columnCells;
    numColumns_ = numColumns;
    n_ = n;
}

template <int D>
void Distribution<D>::partition(MaterialPoints<D>& P, const std::vector<int>& stripOf, int numStrips, int S, int nLast,
                                const std::vector<int>& columnOf)
{
    checkStrips(numStrips);
    std::vector<double> count(numStrips, 0.0);
    for (int s : stripOf) ++count[s];
    const std::vector<int> first = balancedRanges(count, rows());
    std::vector<int> firstCol;
    if (cols_ > 1) {
        std::vector<double> perColumn(numColumns_, 0.0);
        for (int c : columnOf) ++perColumn[c];
        firstCol = nearestRanges(perColumn, cols_);
    }
    setRanges(first, S, nLast, firstCol);
    // Keep this rank's points, numbered by their index in the whole scene.
    std::vector<int> mine;
    for (int p = 0; p < static_cast<int>(stripOf.size()); ++p)
        if (rankOf(stripOf[p], cols_ > 1 ? columnOf[p] : 0) == rank_) mine.push_back(p);
    P.distributed = true;
    P.globalId.resize(P.size());
    for (std::size_t p = 0; p < P.size(); ++p) P.globalId[p] = static_cast<std::int32_t>(p);
    P.forEachArray([&](const char* name, auto& a) {
        if (!P.carries(name)) return;
        std::decay_t<decltype(a)> next;
        next.reserve(mine.size());
        for (int p : mine) next.push_back(a[p]);
        a.swap(next);
    });
}

template <int D> void Distribution<D>::checkStrips(int numStrips) const
{
    if (numStrips < rows())
        require(false, cols_ > 1 ? "number of rows of ranks" : "number of ranks", rows(),
                "at most the number of strips of " + std::to_string(Scheduler<D>::stripWidth) +
                    " cells along the last axis, " + std::to_string(numStrips) +
                    " here (a smaller h, or fewer ranks" + (cols_ > 1 ? ", or more rank columns)" : ")"));
}

template <int D>
void Distribution<D>::partitionHeld(MaterialPoints<D>& P, const std::vector<int>& stripOf, int numStrips, int S, int nLast,
                                    const std::vector<int>& columnOf)
{
    checkStrips(numStrips);
    std::vector<double> count(numStrips, 0.0);
    for (int s : stripOf) ++count[s];
    t_->sum(count.data(), numStrips);  // (whole numbers: exact in any order)
    const std::vector<int> first = balancedRanges(count, rows());
    if (cols_ == 1) {
        sendToOwners(P, stripOf, first);
        setRanges(first, S, nLast);
        return;
    }
    std::vector<double> perColumn(numColumns_, 0.0);
    for (std::size_t p = 0; p < stripOf.size(); ++p)
        if (stripOf[p] >= 0) ++perColumn[columnOf[p]];
    t_->sum(perColumn.data(), numColumns_);
    setRanges(first, S, nLast, nearestRanges(perColumn, cols_));
    std::vector<int> to(stripOf.size());
    for (std::size_t p = 0; p < stripOf.size(); ++p) to[p] = stripOf[p] < 0 ? rank_ : rankOf(stripOf[p], columnOf[p]);
    sendPoints(P, to, false);
}

template <int D>
void Distribution<D>::sendToOwners(MaterialPoints<D>& P, const std::vector<int>& strip, const std::vector<int>& first)
{
    std::vector<int> to(P.size());
    for (std::size_t p = 0; p < P.size(); ++p)
        to[p] = strip[p] < 0 ? rank_
                             : static_cast<int>(std::upper_bound(first.begin(), first.end(), strip[p]) - first.begin()) - 1;
    sendPoints(P, to, false);
}

template <int D> void Distribution<D>::sendPoints(MaterialPoints<D>& P, const std::vector<int>& to, bool neighboursOnly)
{
    const int n = static_cast<int>(P.size());
    // The messages: one per neighbour in the grid of ranks, or one per rank (this one's empty).
    const int nOut = neighboursOnly ? static_cast<int>(neighbours_.size()) : size_;
    const auto slot = [&](int r) { return neighboursOnly ? slotOf(r) : r; };
    std::vector<std::vector<int>> leaving(nOut);
    std::vector<int> keep;
    keep.reserve(n);
    for (int p = 0; p < n; ++p) (to[p] == rank_ ? keep : leaving[slot(to[p])]).push_back(p);
    std::vector<std::vector<char>> out(nOut);
    for (int i = 0; i < nOut; ++i) {
        if (!neighboursOnly && i == rank_) continue;
        Bytes b;
        b.put(static_cast<int>(leaving[i].size()));
        P.forEachArray([&](const char* name, auto& a) {
            if (!P.carries(name)) return;
            for (int p : leaving[i]) b.put(a[p]);
        });
        out[i].swap(b.data);
    }
    std::vector<std::vector<char>> in = neighboursOnly ? t_->neighbourExchange(neighbours_, out) : t_->allToAll(out);
    std::vector<Bytes> from(nOut);
    std::vector<int> arriving(nOut, 0);
    std::size_t total = keep.size();
    for (int i = 0; i < nOut; ++i) {
        if ((!neighboursOnly && i == rank_) || in[i].empty()) continue;
        from[i].data.swap(in[i]);
        arriving[i] = from[i].get<int>();
        total += arriving[i];
    }
    if (total == keep.size() && keep.size() == P.size()) return;  // nothing left, nothing came
    P.forEachArray([&](const char* name, auto& a) {
        if (!P.carries(name)) return;
        using T = typename std::decay_t<decltype(a)>::value_type;
        std::vector<T> merged;
        merged.reserve(total);
        for (int p : keep) merged.push_back(a[p]);
        for (int i = 0; i < nOut; ++i)
            for (int k = 0; k < arriving[i]; ++k) merged.push_back(from[i].get<T>());
        a.swap(merged);
    });
    // Sorted by globalId again, as one process numbers them.
    std::vector<int> order(total);
    for (std::size_t k = 0; k < total; ++k) order[k] = static_cast<int>(k);
    const std::vector<std::int32_t>& id = P.globalId;
    std::sort(order.begin(), order.end(), [&](int a, int b) { return id[a] < id[b]; });
    P.forEachArray([&](const char* name, auto& a) {
        if (!P.carries(name)) return;
        std::decay_t<decltype(a)> sorted(a.size());
        for (std::size_t k = 0; k < total; ++k) sorted[k] = a[order[k]];
        a.swap(sorted);
    });
}

template <int D> std::vector<int> Distribution<D>::nearestRanges(const std::vector<double>& count, int ranks)
{
    // Boundary r at the column boundary whose points before it are nearest to r/ranks of all
    // (the earlier one on a tie); at least one column each. (Whole numbers: exact sums.)
    const int n = static_cast<int>(count.size());
    std::vector<double> before(n + 1, 0.0);
    for (int c = 0; c < n; ++c) before[c + 1] = before[c] + count[c];
    std::vector<int> first(ranks + 1, 0);
    first[ranks] = n;
    for (int r = 1; r < ranks; ++r) {
        const double share = before[n] * r / ranks;
        int b = static_cast<int>(std::lower_bound(before.begin(), before.end(), share) - before.begin());
        if (b > 0 && share - before[b - 1] <= before[std::min(b, n)] - share) --b;
        first[r] = std::min(std::max(b, first[r - 1] + 1), n - (ranks - r));
    }
    return first;
}

template <int D> std::vector<int> Distribution<D>::balancedRanges(const std::vector<double>& count, int ranks)
{
    // Rank r starts at the first strip where the points before it reach r/ranks of all; at least
    // one strip each. (Counts are whole numbers: the sums are exact.)
    const int numStrips = static_cast<int>(count.size());
    double total = 0;
    for (double c : count) total += c;
    std::vector<int> first(ranks + 1, 0);
    first[ranks] = numStrips;
    double before = 0;  // points in the strips before s
    int s = 0;
    for (int r = 1; r < ranks; ++r) {
        while (s < numStrips && before * ranks < total * r) before += count[s++];
        first[r] = std::min(std::max(s, first[r - 1] + 1), numStrips - (ranks - r));
        for (; s < first[r]; ++s) before += count[s];
        for (; s > first[r]; --s) before -= count[s - 1];
    }
    return first;
}

template <int D>
void Distribution<D>::setRanges(const std::vector<int>& first, int S, int nLast, const std::vector<int>& firstColumns)
{
    require(static_cast<int>(first.size()) == rows() + 1, "strip ranges", first.size(),
            "one per row of ranks, and the end: " + std::to_string(rows() + 1));
    require(cols_ == 1 ? firstColumns.empty() : static_cast<int>(firstColumns.size()) == cols_ + 1, "column ranges",
            firstColumns.size(), cols_ == 1 ? std::string("none with one column of ranks")
                                            : "one per column of ranks, and the end: " + std::to_string(cols_ + 1));
    first_ = first;
    firstCol_ = firstColumns;
    setRangesOf(S, nLast);
}

template <int D> void Distribution<D>::setRangesOf(int S, int nLast)
{
    constexpr int W = Scheduler<D>::stripWidth;
    S_ = S;
    nLast_ = nLast;
    const int a = first_[row()], b = first_[row() + 1];
    // A strip s holds the points of base node s W .. s W + W - 1, which reach up to S - 1 planes
    // further.
    planeLo_ = a * W;
    planeHi_ = std::min(nLast, b * W + S - 1);
    ownedLo_ = row() == 0 ? 0 : planeLo_;
    ownedHi_ = row() == rows() - 1 ? nLast : b * W;
    leftShared_ = planeLo_ + S - 1;
    rightShared_ = b * W;
    if (cols_ == 1) return;
    // The same along the first axis for the rank's Scheduler columns; its neighbours in the grid
    // of ranks; the passes of the scatters.
    const int c = column(), ca = firstCol_[c], cb = firstCol_[c + 1];
    colLo_ = ca * columnCells_;
    colHi_ = std::min(n_[0], cb * columnCells_ + S - 1);
    ownedColLo_ = c == 0 ? 0 : colLo_;
    ownedColHi_ = c == cols_ - 1 ? n_[0] : cb * columnCells_;
    neighbours_.clear();
    for (int r = std::max(0, row() - 1); r <= std::min(rows() - 1, row() + 1); ++r)
        for (int k = std::max(0, c - 1); k <= std::min(cols_ - 1, c + 1); ++k)
            if (r * cols_ + k != rank_) neighbours_.push_back(r * cols_ + k);
    Blocks blocks;
    blocks.strips = first_;
    blocks.columns = firstCol_;
    chain_ = std::make_unique<ScatterChain<D>>(n_, S, W, columnCells_, blocks, rank_);
}

template <int D> bool Distribution<D>::writesFirst(int side) const
{
    // At the boundary before strip B, the strip B - 1 (left rank) and B (right rank) share
    // planes; colour 0 (even strips) writes first.
    const int B = side > 0 ? first_[row() + 1] : first_[row()];
    const bool leftFirst = (B - 1) % 2 == 0;
    return side > 0 ? leftFirst : !leftFirst;
}

template <int D>
std::vector<char> Distribution<D>::planes(const Grid<D>& g, int lo, int hi, const std::vector<NodeField>& fields) const
{
    const int stride = g.stride[D - 1];
    Bytes b;
    const auto put = [&](const NodeField& f, int I) {
        for (int c = 0; c < f.width; ++c) b.put(f.data[static_cast<std::size_t>(I) * f.width + c]);
    };
    for (const NodeField& f : fields) {
        for (int I = lo * stride; I < hi * stride; ++I) put(f, I);
        if (phantom_)
            for (int I = lo * stride; I < hi * stride; ++I) phantom_->forEachTwin(I, [&](int t) { put(f, t); });
    }
    return b.data;
}

template <int D>
void Distribution<D>::setPlanes(const Grid<D>& g, int lo, const std::vector<char>& bytes, const std::vector<NodeField>& fields) const
{
    if (bytes.empty()) return;
    const int stride = g.stride[D - 1];
    Bytes b;
    b.data = bytes;
    const auto get = [&](const NodeField& f, int I) {
        for (int c = 0; c < f.width; ++c) f.data[static_cast<std::size_t>(I) * f.width + c] = b.get<double>();
    };
    for (const NodeField& f : fields) {
        for (int I = lo * stride; I < (lo + S_ - 1) * stride; ++I) get(f, I);
        if (phantom_)
            for (int I = lo * stride; I < (lo + S_ - 1) * stride; ++I) phantom_->forEachTwin(I, [&](int t) { get(f, t); });
    }
}

template <int D> void Distribution<D>::afterFirstColour(const Grid<D>& g, const std::vector<NodeField>& fields)
{
    std::vector<char> toLeft, toRight, fromLeft, fromRight;
    if (rank_ > 0 && writesFirst(-1)) toLeft = planes(g, planeLo_, leftShared_, fields);
    if (rank_ < size_ - 1 && writesFirst(1)) toRight = planes(g, rightShared_, rightShared_ + S_ - 1, fields);
    t_->exchange(toLeft, toRight, fromLeft, fromRight);
    setPlanes(g, planeLo_, fromLeft, fields);
    setPlanes(g, rightShared_, fromRight, fields);
}

template <int D> void Distribution<D>::afterPhase(int k, int phases, const Grid<D>& g, const std::vector<NodeField>& fields)
{
    if (cols_ > 1)
        passChain(k, g, fields);
    else if (k == phases / 2 - 1)
        afterFirstColour(g, fields);
}

template <int D> void Distribution<D>::passChain(int k, const Grid<D>& g, const std::vector<NodeField>& fields)
{
    (void)g;
    const auto slot = [&](int r) { return slotOf(r); };
    std::vector<std::vector<char>> out(neighbours_.size());
    // Each node's values, then its twins' (the cracks' phantom nodes, the same on every rank).
    const auto forEachNode = [&](const std::vector<int>& nodes, auto&& f) {
        for (int I : nodes) {
            f(I);
            if (phantom_) phantom_->forEachTwin(I, f);
        }
    };
    for (const auto& pass : chain_->sends(k)) {
        Bytes b;
        for (const NodeField& f : fields)
            forEachNode(pass.nodes, [&](int I) {
                for (int c = 0; c < f.width; ++c) b.put(f.data[static_cast<std::size_t>(I) * f.width + c]);
            });
        out[slot(pass.rank)].swap(b.data);
    }
    std::vector<std::vector<char>> in = t_->neighbourExchange(neighbours_, out);
    for (const auto& pass : chain_->receives(k)) {
        Bytes b;
        b.data.swap(in[slot(pass.rank)]);
        for (const NodeField& f : fields)
            forEachNode(pass.nodes, [&](int I) {
                for (int c = 0; c < f.width; ++c) f.data[static_cast<std::size_t>(I) * f.width + c] = b.get<double>();
            });
    }
}

template <int D> void Distribution<D>::finishScatter(const Grid<D>& g, const std::vector<NodeField>& fields)
{
    if (cols_ > 1) {
        passChain(chain_->numPhases() - 1, g, fields);
        return;
    }
    std::vector<char> toLeft, toRight, fromLeft, fromRight;
    if (rank_ > 0 && !writesFirst(-1)) toLeft = planes(g, planeLo_, leftShared_, fields);
    if (rank_ < size_ - 1 && !writesFirst(1)) toRight = planes(g, rightShared_, rightShared_ + S_ - 1, fields);
    t_->exchange(toLeft, toRight, fromLeft, fromRight);
    setPlanes(g, planeLo_, fromLeft, fields);
    setPlanes(g, rightShared_, fromRight, fields);
}

template <int D> void Distribution<D>::writersOf(int I, std::vector<int>& ranks) const
{
    constexpr int W = Scheduler<D>::stripWidth;
    const int i0 = I % n_[0], iL = I / (D == 3 ? n_[0] * n_[1] : n_[0]);
    const auto s = tilesWriting(iL, W, n_[D - 1], first_.back(), S_);
    const auto c = tilesWriting(i0, columnCells_, n_[0], numColumns_, S_);
    ranks.clear();
    for (int si = s[0]; si <= s[1]; ++si)
        for (int ci = c[0]; ci <= c[1]; ++ci) ranks.push_back(rankOf(si, ci));
    std::sort(ranks.begin(), ranks.end());
    ranks.erase(std::unique(ranks.begin(), ranks.end()), ranks.end());
}

template <int D> bool Distribution<D>::sharedNode(int I) const
{
    std::vector<int> ranks;
    writersOf(I, ranks);
    return ranks.size() > 1;
}

template <int D>
template <class T, class NodeOf>
void Distribution<D>::shareWithWriters(std::vector<T>& items, NodeOf&& nodeOf)
{
    std::vector<Bytes> out(neighbours_.size());
    std::vector<int> writers;
    for (const T& item : items) {
        writersOf(nodeOf(item), writers);
        for (int q : writers)
            if (q != rank_) out[slotOf(q)].put(item);
    }
    std::vector<std::vector<char>> bytes(neighbours_.size());
    for (std::size_t i = 0; i < out.size(); ++i) bytes[i].swap(out[i].data);
    for (auto& theirs : t_->neighbourExchange(neighbours_, bytes)) {
        Bytes b;
        b.data.swap(theirs);
        while (!b.done()) items.push_back(b.template get<T>());
    }
}

template <int D> void Distribution<D>::applyRecordsBlocks(std::vector<NodeRecord<D>>& mine, NodeField f)
{
    // Each contribution goes to the other ranks that write its node; every writer then applies
    // all of them in key order.
    shareWithWriters(mine, [](const NodeRecord<D>& r) { return r.regular; });
    std::stable_sort(mine.begin(), mine.end(), [](const NodeRecord<D>& a, const NodeRecord<D>& c) {
        return a.key[0] != c.key[0] ? a.key[0] < c.key[0] : a.key[1] < c.key[1];
    });
    for (const auto& r : mine)
        for (int d = 0; d < D; ++d) f.data[static_cast<std::size_t>(r.node) * D + d] += r.value[d];
}

template <int D>
void Distribution<D>::applyRecords(std::vector<NodeRecord<D>>& left, std::vector<NodeRecord<D>>& right, NodeField f)
{
    if (cols_ > 1) {
        applyRecordsBlocks(left, f);
        return;
    }
    const auto bytes = [](const std::vector<NodeRecord<D>>& r) {
        Bytes b;
        for (const auto& x : r) b.put(x);
        return b.data;
    };
    std::vector<char> fromLeft, fromRight;
    t_->exchange(bytes(left), bytes(right), fromLeft, fromRight);
    const auto apply = [&](std::vector<NodeRecord<D>>& mine, const std::vector<char>& theirs) {
        Bytes b;
        b.data = theirs;
        while (!b.done()) mine.push_back(b.template get<NodeRecord<D>>());
        std::stable_sort(mine.begin(), mine.end(), [](const NodeRecord<D>& a, const NodeRecord<D>& c) {
            return a.key[0] != c.key[0] ? a.key[0] < c.key[0] : a.key[1] < c.key[1];
        });
        for (const auto& r : mine)
            for (int d = 0; d < D; ++d) f.data[static_cast<std::size_t>(r.node) * D + d] += r.value[d];
    };
    apply(left, fromLeft);
    apply(right, fromRight);
}

template <int D>
void Distribution<D>::ghostsBlocks(const MaterialPoints<D>& P, const Grid<D>& g, double reach, GhostPoints<D>& out)
{
    // Every neighbour gets the points within the margin of its block (the tiles' cells along the
    // first and the last axis).
    constexpr int W = Scheduler<D>::stripWidth;
    const double margin = reach + 2 * g.h;
    struct Box {
        double lo0, hi0, loL, hiL;
    };
    std::vector<Box> box;
    for (int q : neighbours_) {
        const int r = q / cols_, c = q % cols_;
        box.push_back({g.origin[0] + firstCol_[c] * columnCells_ * g.h - margin,
                       g.origin[0] + firstCol_[c + 1] * columnCells_ * g.h + margin,
                       g.origin[D - 1] + first_[r] * W * g.h - margin, g.origin[D - 1] + first_[r + 1] * W * g.h + margin});
    }
    std::vector<Bytes> to(neighbours_.size());
    for (std::size_t p = 0; p < P.size(); ++p) {
        const double x0 = P.x[p][0], xL = P.x[p][D - 1];
        for (std::size_t i = 0; i < box.size(); ++i)
            if (x0 >= box[i].lo0 && x0 <= box[i].hi0 && xL >= box[i].loL && xL <= box[i].hiL) {
                to[i].put(P.globalId[p]);
                to[i].put(P.x[p]);
                to[i].put(P.mass(p));
                to[i].put(P.history[p]);
                to[i].put(P.damage[p]);
            }
    }
    std::vector<std::vector<char>> bytes(neighbours_.size());
    for (std::size_t i = 0; i < to.size(); ++i) bytes[i].swap(to[i].data);
    std::vector<Bytes> from(neighbours_.size());
    auto in = t_->neighbourExchange(neighbours_, bytes);
    for (std::size_t i = 0; i < in.size(); ++i) from[i].data.swap(in[i]);
    collectGhosts(from, out);
}

template <int D>
void Distribution<D>::ghosts(const MaterialPoints<D>& P, const Grid<D>& g, double reach, GhostPoints<D>& out)
{
    if (cols_ > 1) {
        ghostsBlocks(P, g, reach, out);
        return;
    }
    // The planes this rank owns, widened by the reach and by the two cells a point's base node
    // may lie from its position: a neighbour's point nearer than that is sent.
    const double lo = g.origin[D - 1] + (first_[rank_] * Scheduler<D>::stripWidth) * g.h;
    const double hi = g.origin[D - 1] + (first_[rank_ + 1] * Scheduler<D>::stripWidth) * g.h;
    const double margin = reach + 2 * g.h;
    Bytes toLeft, toRight;
    for (std::size_t p = 0; p < P.size(); ++p) {
        const double z = P.x[p][D - 1];
        for (Bytes* b : {rank_ > 0 && z <= lo + margin ? &toLeft : nullptr,
                         rank_ < size_ - 1 && z >= hi - margin ? &toRight : nullptr})
            if (b) {
                b->put(P.globalId[p]);
                b->put(P.x[p]);
                b->put(P.mass(p));
                b->put(P.history[p]);
                b->put(P.damage[p]);
            }
    }
    Bytes fromLeft, fromRight;
    t_->exchange(toLeft.data, toRight.data, fromLeft.data, fromRight.data);
    std::vector<Bytes> from(2);
    from[0].data.swap(fromLeft.data);
    from[1].data.swap(fromRight.data);
    collectGhosts(from, out);
}

template <int D> void Distribution<D>::collectGhosts(std::vector<Bytes>& from, GhostPoints<D>& out)
{
    // Each neighbour sent its points in globalId order: merged into one sorted list.
    struct Ghost {
        std::int32_t id;
        Vec<D> x;
        double mass, history, damage;
    };
    std::vector<Ghost> all;
    for (Bytes& b : from)
        while (!b.done()) {
            Ghost q;
            q.id = b.get<std::int32_t>();
            q.x = b.get<Vec<D>>();
            q.mass = b.get<double>();
            q.history = b.get<double>();
            q.damage = b.get<double>();
            all.push_back(q);
        }
    std::stable_sort(all.begin(), all.end(), [](const Ghost& a, const Ghost& b) { return a.id < b.id; });
    out.x.clear();
    out.mass.clear();
    out.history.clear();
    out.damage.clear();
    out.id.clear();
    for (const Ghost& q : all) {
        out.id.push_back(q.id);
        out.x.push_back(q.x);
        out.mass.push_back(q.mass);
        out.history.push_back(q.history);
        out.damage.push_back(q.damage);
    }
}

template <int D>
template <class F>
void Distribution<D>::forEachInBox(const Grid<D>& g, const int* lo, const int* hi, F&& f) const
{
    // Regular nodes of the box, x fastest, each followed by its twins.
    int i[3] = {0, 0, 0};
    for (i[2] = D == 3 ? lo[2] : 0; i[2] <= (D == 3 ? hi[2] : 0); ++i[2])
        for (i[1] = lo[1]; i[1] <= hi[1]; ++i[1])
            for (i[0] = lo[0]; i[0] <= hi[0]; ++i[0]) {
                int I = 0;
                for (int d = 0; d < D; ++d) I += i[d] * g.stride[d];
                f(I, i[0], i[D - 1]);
                if (phantom_) phantom_->forEachTwin(I, [&](int t) { f(t, i[0], i[D - 1]); });
            }
}

template <int D> void Distribution<D>::shareBox(Grid<D>& g, const int* lo, const int* hi)
{
    std::vector<double> v;
    forEachInBox(g, lo, hi, [&](int I, int i0, int plane) {
        const bool mine = plane >= ownedLo_ && plane < ownedHi_ && i0 >= ownedColLo_ && i0 < ownedColHi_;
        v.push_back(mine ? g.mass[I] : 0.0);
        for (int d = 0; d < D; ++d) v.push_back(mine ? g.momentum[I][d] : 0.0);
    });
    t_->sum(v.data(), static_cast<int>(v.size()));  // one rank owns each plane: x + 0 is x, exactly
    std::size_t k = 0;
    forEachInBox(g, lo, hi, [&](int I, int, int) {
        g.mass[I] = v[k++];
        for (int d = 0; d < D; ++d) g.momentum[I][d] = v[k++];
    });
}

template <int D> void Distribution<D>::restoreBox(Grid<D>& g, const int* lo, const int* hi)
{
    forEachInBox(g, lo, hi, [&](int I, int i0, int plane) {
        if (plane >= planeLo_ && plane < planeHi_ && i0 >= colLo_ && i0 < colHi_) return;
        g.mass[I] = 0;
        g.momentum[I].setZero();
    });
}

template <int D> void Distribution<D>::shareNodes(const Grid<D>& g, std::vector<int>& nodes)
{
    if (cols_ > 1) {  // every node goes to the other ranks that write it
        shareWithWriters(nodes, [](int I) { return I; });
        return;
    }
    Bytes toLeft, toRight, fromLeft, fromRight;
    for (int I : nodes) {
        const int side = sharedSide(I / g.stride[D - 1]);
        if (side != 0) (side < 0 ? toLeft : toRight).put(I);
    }
    t_->exchange(toLeft.data, toRight.data, fromLeft.data, fromRight.data);
    for (Bytes* b : {&fromLeft, &fromRight})
        while (!b->done()) nodes.push_back(b->get<int>());
}

template <int D> int Distribution<D>::localIndex(const MaterialPoints<D>& P, int id) const
{
    const auto it = std::lower_bound(P.globalId.begin(), P.globalId.end(), id);
    return it != P.globalId.end() && *it == id ? static_cast<int>(it - P.globalId.begin()) : -1;
}

template class Distribution<2>;
template class Distribution<3>;

}  // namespace emp
