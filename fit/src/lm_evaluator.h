// The bounded LM's evaluator (internal to fit/): the passes over a problem's pixels that give
// the cost, or the cost with the gradient and the Gauss-Newton matrix (a Jacobian pass), at a
// point of the box coordinates; and the move of a Jacobian pass along the linear entries without
// a pass (ShiftLinear). The minimiser (bounded_lm.cpp) calls only what is declared here.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "lm_problem.h"
#include "lm_geometry.h"

namespace shadefit::fit::internal {

// The Gram matrix of one group of a Jacobian pass's rows (a colour channel when the Jet has
// one slot per table row, else every residual): gram = sum q q^T over the rows
// q = [slot derivatives..., (w,) r], `unknown` the unknown each slot stands for. With `mixed`
// the row carries w, the derivative of the Fresnel-lobe product along both its rows
// (F_v L_v e: ShiftLinear).
struct GroupGram {
  std::vector<int> unknown;
  bool mixed = false;
  int fresnel = -1, lobe = -1;  // Slots of the Fresnel and lobe terms' rows (with `mixed`).
  Eigen::MatrixXd gram;
};

// One pass's sums: cost = 0.5 sum r^2, g = J^T r, h = J^T J (row-major, N x N), over the
// unknowns [y_0 .. y_{n-1}, e]; for a Jacobian pass, the Gram matrices they were scattered from.
struct Sums {
  double cost = 0;
  std::vector<double> g, h;
  bool finite = true;
  std::vector<GroupGram> groups;
};

// Cost only (no derivatives): doubles through the twin.
Sums Cost(const BoundedLmProblem& problem, const Geometry& geo, const std::vector<Chunk>& chunks,
          const std::vector<double>& y, double e);

// Cost, gradient and Gauss-Newton matrix in one pass (lm_evaluator.cpp says how), in the Jet
// layout the problem asks for and the model's structure allows (model_structure.h).
Sums Jacobian(const BoundedLmProblem& problem, const Geometry& geo,
              const std::vector<Chunk>& chunks, const std::vector<double>& y, double e);

// Moves a Jacobian pass at x to x + delta, delta non-zero on linear entries only (LinearEntries:
// the radiance is jointly affine in them), without a pass over the pixels; false (the pass left
// as it was) where its rows do not carry what that needs. Each row q = [J, (w,) r] becomes M q:
// - r' = r + J delta, exactly, the radiance being affine in the entries moved;
// - the derivative columns of the terms are their own rows' derivatives times the other terms'
//   values (Diffuse_v n.l e, Fresnel_v Lobe e, Fresnel Lobe_v e; one row per term: TermRows);
//   along a linear entry a term is affine, so its derivative does not change and its value
//   changes by delta times it: the lobe column gains delta_fresnel w, w = Fresnel_v Lobe_v e
//   (the mixed column), and no other column changes.
// So gram' = M gram M^T. The new cost is a difference of the old sums: where it falls below
// kShiftCancellation of the old one, too few of their digits are left, and the caller makes a
// fresh pass instead.
bool ShiftLinear(const std::vector<double>& delta, Sums* sums);

}  // namespace shadefit::fit::internal
