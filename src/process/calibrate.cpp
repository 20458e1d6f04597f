#include "amctl/process/calibrate.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/numerics/least_squares.hpp"
#include "amctl/process/stats.hpp"

namespace amctl::process {

CalibrationResult calibrate_durations(const DurationEstimator& estimator,
                                      const std::vector<double>& measured,
                                      const std::vector<CalibrationParameter>& params,
                                      const CalibrationOptions& opt) {
  const std::size_t n = measured.size(), P = params.size();
  if (P == 0) throw Error("calibration: no parameters to fit");
  if (n < P) {
    throw Error(fmt::format("calibration: {} measured print(s) cannot determine {} parameters; "
                            "time more prints or fit fewer parameters",
                            n, P));
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(measured[i]) || measured[i] <= 0.0) {
      throw Error(fmt::format("calibration: measured duration {} must be > 0 s, got {}", i + 1,
                              measured[i]));
    }
  }
  Eigen::VectorXd lo(P), hi(P), x(P);
  for (std::size_t j = 0; j < P; ++j) {
    const auto& p = params[j];
    if (!(p.lower > 0.0 && p.upper > p.lower && std::isfinite(p.upper))) {
      throw Error(fmt::format("calibration: bounds of {} must satisfy 0 < lower < upper, got "
                              "[{}, {}]",
                              p.name, p.lower, p.upper));
    }
    if (!(p.initial >= p.lower && p.initial <= p.upper)) {
      throw Error(fmt::format("calibration: start value {} of {} lies outside [{}, {}]",
                              p.initial, p.name, p.lower, p.upper));
    }
    lo(j) = std::log(p.lower);
    hi(j) = std::log(p.upper);
    x(j) = std::log(p.initial);
  }
  CalibrationResult res;
  auto predict = [&](const Eigen::VectorXd& lx) {
    std::vector<double> pv(P);
    for (std::size_t j = 0; j < P; ++j) pv[j] = std::exp(lx(static_cast<Eigen::Index>(j)));
    ++res.evaluations;
    auto out = estimator(pv);
    if (out.size() != n) {
      throw Error(fmt::format("calibration: estimator returned {} durations for {} samples",
                              out.size(), n));
    }
    return out;
  };
  auto residuals = [&](const std::vector<double>& pred) {
    Eigen::VectorXd r(n);
    for (std::size_t i = 0; i < n; ++i) {
      r(static_cast<Eigen::Index>(i)) =
          opt.relative ? (measured[i] - pred[i]) / measured[i] : measured[i] - pred[i];
    }
    return r;
  };
  auto jacobian = [&](const Eigen::VectorXd& lx) {
    Eigen::MatrixXd J(n, P);
    for (std::size_t j = 0; j < P; ++j) {
      const auto jj = static_cast<Eigen::Index>(j);
      Eigen::VectorXd xp = lx, xm = lx;
      xp(jj) = std::min(hi(jj), lx(jj) + opt.log_step);
      xm(jj) = std::max(lo(jj), lx(jj) - opt.log_step);
      const double h = xp(jj) - xm(jj);
      const Eigen::VectorXd rp = residuals(predict(xp)), rm = residuals(predict(xm));
      J.col(jj) = h > 0 ? Eigen::VectorXd((rp - rm) / h) : Eigen::VectorXd::Zero(n);
    }
    return J;
  };
  std::vector<double> pred = predict(x);
  Eigen::VectorXd r = residuals(pred);
  double cost = r.squaredNorm();
  Eigen::MatrixXd J = jacobian(x);
  // A limit that no move reaches (e.g. a maximum speed above every requested feed) has a zero
  // derivative, and gradient steps never move it. Such parameters get a coarse geometric
  // grid search across their bounds first.
  for (std::size_t j = 0; j < P; ++j) {
    const auto jj = static_cast<Eigen::Index>(j);
    if (J.col(jj).norm() > 1e-12 * (1.0 + r.norm())) continue;
    constexpr int kGrid = 24;
    Eigen::VectorXd best_x = x;
    for (int g = 0; g <= kGrid; ++g) {
      Eigen::VectorXd xt = x;
      xt(jj) = lo(jj) + (hi(jj) - lo(jj)) * g / kGrid;
      const auto pt = predict(xt);
      const Eigen::VectorXd rt = residuals(pt);
      if (rt.squaredNorm() < cost) {
        cost = rt.squaredNorm();
        best_x = xt;
        pred = pt;
        r = rt;
      }
    }
    x = best_x;
  }
  // Levenberg-Marquardt in log space within the bounds; parameters with no effect (a zero
  // Jacobian column) are held.
  numerics::LevenbergMarquardtOptions lm;
  lm.max_iterations = opt.max_iterations;
  lm.relative_tolerance = opt.tolerance;
  lm.hold_flat_parameters = true;
  std::vector<double> last_pred;  // what residuals() last predicted
  const auto fit = numerics::levenberg_marquardt(
      x, r,
      [&](const Eigen::VectorXd& lx) {
        last_pred = predict(lx);
        return residuals(last_pred);
      },
      jacobian, [&](Eigen::VectorXd& lx) { lx = lx.cwiseMax(lo).cwiseMin(hi); },
      [&](const Eigen::VectorXd&, const Eigen::VectorXd& rn) {
        pred = last_pred;
        r = rn;
      },
      lm);
  cost = fit.cost;
  res.iterations = fit.iterations;
  res.converged = fit.stop != numerics::LevenbergMarquardtStop::max_iterations;
  std::vector<bool> active(P, true);
  J = jacobian(x);
  for (std::size_t j = 0; j < P; ++j) {
    active[j] = J.col(static_cast<Eigen::Index>(j)).norm() > 1e-12 * (1.0 + r.norm());
  }
  if (std::none_of(active.begin(), active.end(), [](bool a) { return a; })) {
    throw Error("calibration: no parameter changes the estimated durations of these prints");
  }
  // Covariance in log space over the identifiable parameters: s^2 (J'J)^-1.
  std::vector<std::size_t> act;
  for (std::size_t j = 0; j < P; ++j)
    if (active[j]) act.push_back(j);
  const std::size_t k = act.size();
  Eigen::MatrixXd Ja(n, k);
  for (std::size_t c = 0; c < k; ++c) Ja.col(static_cast<Eigen::Index>(c)) = J.col(static_cast<Eigen::Index>(act[c]));
  res.dof = n - k;
  const double s2 = res.dof > 0 ? cost / static_cast<double>(res.dof)
                                : std::numeric_limits<double>::quiet_NaN();
  const Eigen::MatrixXd cov = (Ja.transpose() * Ja).completeOrthogonalDecomposition().pseudoInverse() * s2;
  const double t = res.dof > 0 ? student_t_quantile(0.5 + 0.5 * opt.confidence,
                                                    static_cast<double>(res.dof))
                               : std::numeric_limits<double>::quiet_NaN();
  res.names.resize(P);
  res.values.resize(P);
  res.std_errors.assign(P, 0.0);
  res.ci_lo.resize(P);
  res.ci_hi.resize(P);
  res.identifiable = active;
  res.correlation.assign(P, std::vector<double>(P, 0.0));
  for (std::size_t j = 0; j < P; ++j) {
    res.names[j] = params[j].name;
    res.values[j] = std::exp(x(static_cast<Eigen::Index>(j)));
    res.ci_lo[j] = res.ci_hi[j] = res.values[j];
    res.correlation[j][j] = 1.0;
  }
  for (std::size_t a = 0; a < k; ++a) {
    const auto aa = static_cast<Eigen::Index>(a);
    const double se_log = std::sqrt(cov(aa, aa));
    const std::size_t j = act[a];
    res.std_errors[j] = res.values[j] * se_log;
    res.ci_lo[j] = res.values[j] * std::exp(-t * se_log);
    res.ci_hi[j] = res.values[j] * std::exp(t * se_log);
    for (std::size_t b = 0; b < k; ++b) {
      const auto bb = static_cast<Eigen::Index>(b);
      res.correlation[j][act[b]] = cov(aa, bb) / std::sqrt(cov(aa, aa) * cov(bb, bb));
    }
  }
  res.measured_s = measured;
  res.predicted_s = pred;
  double ss = 0, ssr = 0;
  for (std::size_t i = 0; i < n; ++i) {
    res.residual_s.push_back(measured[i] - pred[i]);
    res.relative_residual.push_back((measured[i] - pred[i]) / measured[i]);
    ss += res.residual_s.back() * res.residual_s.back();
    ssr += res.relative_residual.back() * res.relative_residual.back();
  }
  res.rms_s = std::sqrt(ss / static_cast<double>(n));
  res.rms_relative = std::sqrt(ssr / static_cast<double>(n));
  return res;
}

}  // namespace amctl::process
