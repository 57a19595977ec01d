// The crack diagnostics' searches (the Python EigenErosion's front and tips, doc/fracture.md,
// "Crack diagnostics"): which eroded points form the crack grown from its origin, and which
// recent points have a neighbour farther from the origin. They run at every record of a
// cracking scene, so they are here rather than in Python: the same answers, without building two
// k-d trees and a labelled box of cells per record.
//
// Positions are rows of 3 numbers (x, y, z; z = 0 in 2D), row-major. A squared distance is
// summed over the axes in order, ((d0^2 + d1^2) + d2^2), as numpy's row sums are, so that a
// distance at the threshold compares as it does in the Python forms
// (tests/python/test_erosion.py).
#pragma once
#include <vector>

namespace emp::crackfront {

/// Which of the n points x belong to the crack grown from `origin` (3 numbers): the points whose
/// cell (floor(x / R) on each axis) is connected to the cell of the point nearest the origin (the
/// first of the nearest in row order) through occupied cells that share a face, an edge or a
/// corner. Empty for n = 0. R > 0.
/// If `squared` is given, it receives each point's squared distance from the origin.
std::vector<char> mainCrack(const double* x, long n, const double* origin, double R,
                            std::vector<double>* squared = nullptr);

/// For each of the nr points xr: whether a point j of the nm points xm lies within the squared
/// distance R2 of it (|xm_j - xr_i|^2 <= R2) and farther from the origin (r[j] > rr[i], the
/// squared distances given). R >= sqrt(R2) bounds the search: the points are binned in cells of
/// a hair more than R.
std::vector<char> fartherWithin(const double* xm, const double* r, long nm, const double* xr, const double* rr,
                                long nr, double R, double R2);

/// The tips among the nr recent points xr (squared distances rr from the origin; farther[i]:
/// it has a farther neighbour, fartherWithin): those without a farther neighbour, from the
/// farthest (of two at the same distance, the first row first: numpy's stable argsort of -rr),
/// each kept unless a tip kept before lies within the squared distance R2 of it (|x - t|^2 > R2
/// to be kept). Appends their row indices to `tips` and returns true; returns false (tips
/// untouched) when a candidate's distance is NaN (the caller's numpy merge orders those,
/// EigenErosion._mergedTips).
bool mergedTips(const double* xr, const double* rr, const std::vector<char>& farther, long nr, double R2,
                std::vector<long>& tips);

}  // namespace emp::crackfront
