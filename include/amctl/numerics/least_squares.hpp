#pragma once
// Nonlinear least squares: minimise |r(p)|^2 by Levenberg-Marquardt.
//
// Each iteration solves (J'J + lambda D) delta = -J'r, D the diagonal of J'J (each entry at
// least 1e-12), projects p + delta onto the caller's bounds and accepts it when the cost
// falls; lambda then shrinks by 3 (to at least 1e-12), else grows by 4 and the step is tried
// again (at most 30 times). The search stops when an accepted step lowers the cost by less
// than a relative tolerance, when no step lowers it (a minimum at this resolution), or after
// max_iterations. docs/numerics.md.
#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Dense>

namespace amctl::numerics {

struct LevenbergMarquardtOptions {
  int max_iterations = 200;
  /// Stop once an accepted step lowers the cost by less than this fraction of it.
  double relative_tolerance = 1e-13;
  double initial_lambda = 1e-3;
  /// Hold the parameters whose Jacobian column is flat (norm <= 1e-12 (1 + |r|)) at their
  /// value in each iteration: they have no effect the data can see.
  bool hold_flat_parameters = false;
};

enum class LevenbergMarquardtStop {
  converged,       ///< an accepted step lowered the cost by less than the tolerance
  no_descent,      ///< no step lowered the cost: a minimum at this resolution
  max_iterations,  ///< the iteration budget ran out
};

struct LevenbergMarquardtResult {
  double cost = 0.0;        ///< |r|^2 at the returned parameters
  int iterations = 0;       ///< iterations begun (the last one may have found no step)
  int accepted_steps = 0;   ///< steps that lowered the cost
  LevenbergMarquardtStop stop = LevenbergMarquardtStop::max_iterations;
};

/// Levenberg-Marquardt from p (changed in place). P is indexable with p[i] and has size()
/// (an Eigen vector, std::array, std::vector). residuals(p) -> Eigen::VectorXd, jacobian(p) ->
/// Eigen::MatrixXd (rows: residuals, columns: parameters), project(p&) puts p back into its
/// bounds, on_accept(p, r) is told of each accepted point (its r; for a caller that keeps
/// what it computed with it). r0 is residuals(p) (the caller has it already).
template <class P, class Residuals, class Jacobian, class Project, class OnAccept>
LevenbergMarquardtResult levenberg_marquardt(P& p, Eigen::VectorXd r0, const Residuals& residuals,
                                             const Jacobian& jacobian, const Project& project,
                                             const OnAccept& on_accept,
                                             const LevenbergMarquardtOptions& options) {
  LevenbergMarquardtResult res;
  Eigen::VectorXd r = std::move(r0);
  res.cost = r.squaredNorm();
  double lambda = options.initial_lambda;
  const auto n = static_cast<Eigen::Index>(p.size());
  std::vector<bool> held(static_cast<std::size_t>(n), false);
  for (int it = 0; it < options.max_iterations; ++it) {
    res.iterations = it + 1;
    const Eigen::MatrixXd j = jacobian(p);
    if (options.hold_flat_parameters) {
      for (Eigen::Index c = 0; c < n; ++c) held[static_cast<std::size_t>(c)] = !(j.col(c).norm() > 1e-12 * (1.0 + r.norm()));
    }
    const Eigen::MatrixXd jtj = j.transpose() * j;
    Eigen::VectorXd rhs = -(j.transpose() * r);
    for (Eigen::Index c = 0; c < n; ++c)
      if (held[static_cast<std::size_t>(c)]) rhs(c) = 0.0;
    bool improved = false;
    for (int tries = 0; tries < 30; ++tries) {
      Eigen::MatrixXd a = jtj;
      for (Eigen::Index c = 0; c < n; ++c) {
        if (held[static_cast<std::size_t>(c)]) {
          a.row(c).setZero();
          a.col(c).setZero();
          a(c, c) = 1.0;
        } else {
          a(c, c) += lambda * std::max(jtj(c, c), 1e-12);
        }
      }
      const Eigen::VectorXd delta = a.ldlt().solve(rhs);
      P q = p;
      for (Eigen::Index c = 0; c < n; ++c) q[static_cast<std::size_t>(c)] += delta(c);
      project(q);
      Eigen::VectorXd rq = residuals(q);
      const double cq = rq.squaredNorm();
      if (std::isfinite(cq) && cq < res.cost) {
        const double rel = (res.cost - cq) / std::max(res.cost, 1e-300);
        p = q;
        on_accept(static_cast<const P&>(p), static_cast<const Eigen::VectorXd&>(rq));
        r = std::move(rq);
        res.cost = cq;
        ++res.accepted_steps;
        lambda = std::max(lambda / 3.0, 1e-12);
        improved = true;
        if (rel < options.relative_tolerance) {
          res.stop = LevenbergMarquardtStop::converged;
          return res;
        }
        break;
      }
      lambda *= 4.0;
    }
    if (!improved) {
      res.stop = LevenbergMarquardtStop::no_descent;
      return res;
    }
  }
  res.stop = LevenbergMarquardtStop::max_iterations;
  return res;
}

/// Levenberg-Marquardt without an accept hook.
template <class P, class Residuals, class Jacobian, class Project>
LevenbergMarquardtResult levenberg_marquardt(P& p, Eigen::VectorXd r0, const Residuals& residuals,
                                             const Jacobian& jacobian, const Project& project,
                                             const LevenbergMarquardtOptions& options) {
  return levenberg_marquardt(p, std::move(r0), residuals, jacobian, project,
                             [](const P&, const Eigen::VectorXd&) {}, options);
}

}  // namespace amctl::numerics
