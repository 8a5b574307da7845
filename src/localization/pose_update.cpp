#include "localization/pose_update.h"

#include <ceres/ceres.h>
#include <ceres/manifold.h>
#include <ceres/tiny_solver.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <opencv2/calib3d.hpp>
#include <optional>

#include "common/status.h"

namespace twocam::localization {
namespace {

double wrapAngle(double a) { return std::atan2(std::sin(a), std::cos(a)); }

Eigen::Matrix3d planarRotation(double yaw) {
  Eigen::Matrix3d G = Eigen::Matrix3d::Identity();
  G.topLeftCorner<2, 2>() = Eigen::Rotation2Dd(yaw).toRotationMatrix();
  return G;
}

/// A pose as the solver's parameters (Eigen quaternion, translation), converted once for many
/// residuals.
struct PoseParameters {
  PoseParameters() = default;
  explicit PoseParameters(const Eigen::Isometry3d& T) : q(T.linear()), t(T.translation()) {}
  bool residual(const StereoResidual& f, Eigen::Vector3d* r) const {
    return f(q.coeffs().data(), t.data(), r->data());
  }
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
};

/// The per-observation cost of the solve: StereoResidual with analytic Jacobians.
class StereoCost final : public ceres::SizedCostFunction<3, 4, 3> {
 public:
  explicit StereoCost(const StereoResidual& f) : f_(f) {}
  bool Evaluate(double const* const* parameters,
                double* residuals,
                double** jacobians) const override {
    return stereoResidualWithJacobians(f_,
                                       parameters[0],
                                       parameters[1],
                                       residuals,
                                       jacobians != nullptr ? jacobians[0] : nullptr,
                                       jacobians != nullptr ? jacobians[1] : nullptr);
  }

 private:
  StereoResidual f_;
};

/// Ceres' robustification of one observation's residual block (Triggs' correction,
/// internal/ceres/corrector.cc): the residual r (3) and its row-major Jacobian blocks J (3 x
/// cols) and J2 (3 x cols2; null: none) are scaled by sqrt(rho'), with the rank-one curvature
/// term where rho'' > 0.
/// Ceres charges such a block 0.5 rho(s), where 0.5 |corrected residual|^2 is less (rho(s) >=
/// s rho'(s) for the concave Huber and Cauchy losses); the return value rho(s) - |corrected
/// r|^2 >= 0 is that difference, which the callers carry in one extra row with a zero Jacobian.
double robustify(const ceres::LossFunction& loss,
                 double* r,
                 double* J,
                 int cols,
                 double* J2 = nullptr,
                 int cols2 = 0) {
  const double s = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
  double rho[3];
  loss.Evaluate(s, rho);
  const double sqrt_rho1 = std::sqrt(rho[1]);
  double scaling = sqrt_rho1;
  double alpha_sq_norm = 0.0;
  if (s > 0.0 && rho[2] > 0.0) {
    const double alpha = 1.0 - std::sqrt(1.0 + 2.0 * s * rho[2] / rho[1]);
    scaling = sqrt_rho1 / (1.0 - alpha);
    alpha_sq_norm = alpha / s;
  }
  // J = sqrt(rho') (J - alpha^2/s r r^T J), r uncorrected.
  const auto correct = [&](double* block, int n) {
    for (int c = 0; c < n; ++c) {
      const double r_t_j = block[c] * r[0] + block[n + c] * r[1] + block[2 * n + c] * r[2];
      for (int i = 0; i < 3; ++i) {
        block[i * n + c] = sqrt_rho1 * (block[i * n + c] - alpha_sq_norm * r[i] * r_t_j);
      }
    }
  };
  if (J != nullptr) correct(J, cols);
  if (J2 != nullptr) correct(J2, cols2);
  for (int i = 0; i < 3; ++i) r[i] *= scaling;
  return rho[0] - (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
}

/// All stereo residuals of a frame in one cost function (StereoCostLayout::kOneBlock): rows
/// 3k..3k+2 are observation k's, robustified inside by the loss exactly as Ceres robustifies a
/// residual block of its own (robustify), plus one last row with a zero Jacobian that carries
/// the rest of Ceres' cost: the cost, the gradient, the Gauss-Newton matrix and the trust
/// region's model are those of the per-observation problem, up to rounding.
class StereoBatchCost final : public ceres::CostFunction {
 public:
  explicit StereoBatchCost(const std::vector<StereoResidual>& residuals) : residuals_(residuals) {
    set_num_residuals(3 * static_cast<int>(residuals.size()) + 1);
    mutable_parameter_block_sizes()->push_back(4);
    mutable_parameter_block_sizes()->push_back(3);
  }
  /// The loss of every observation (not owned); null = plain least squares.
  void setLoss(const ceres::LossFunction* loss) { loss_ = loss; }

  bool Evaluate(double const* const* parameters,
                double* residuals,
                double** jacobians) const override {
    const size_t n = residuals_.size();
    double* j_q = jacobians != nullptr ? jacobians[0] : nullptr;
    double* j_t = jacobians != nullptr ? jacobians[1] : nullptr;
    double slack = 0.0;
    for (size_t k = 0; k < n; ++k) {
      double* r = residuals + 3 * k;
      double* j_qk = j_q != nullptr ? j_q + 12 * k : nullptr;
      double* j_tk = j_t != nullptr ? j_t + 9 * k : nullptr;
      if (!stereoResidualWithJacobians(residuals_[k], parameters[0], parameters[1], r, j_qk, j_tk))
        return false;
      if (loss_ == nullptr) continue;
      slack += robustify(*loss_, r, j_qk, 4, j_tk, 3);
    }
    residuals[3 * n] = std::sqrt(std::max(0.0, slack));
    if (j_q != nullptr) std::fill(j_q + 12 * n, j_q + 12 * n + 4, 0.0);
    if (j_t != nullptr) std::fill(j_t + 9 * n, j_t + 9 * n + 3, 0.0);
    return true;
  }

 private:
  const std::vector<StereoResidual>& residuals_;
  const ceres::LossFunction* loss_ = nullptr;
};

/// The normalised stereo residual of a point p_c in the left camera (false behind it) and, when
/// J_r is given, its Jacobian with respect to p_c.
bool cameraResidual(const StereoResidual& f,
                    const Eigen::Vector3d& p_c,
                    double* residual,
                    Eigen::Matrix3d* J_r) {
  if (!(p_c.z() > 1e-3)) return false;
  const double inv_z = 1.0 / p_c.z();
  residual[0] = (f.cx + f.fx * p_c.x() * inv_z - f.u) * f.inv_sigma_px;
  residual[1] = (f.cy + f.fy * p_c.y() * inv_z - f.v) * f.inv_sigma_px;
  residual[2] = (f.fb * inv_z - f.d) * f.inv_sigma_d;
  if (J_r != nullptr) {
    *J_r << f.fx * inv_z * f.inv_sigma_px, 0.0,
        -f.fx * p_c.x() * inv_z * inv_z * f.inv_sigma_px,                                      //
        0.0, f.fy * inv_z * f.inv_sigma_px, -f.fy * p_c.y() * inv_z * inv_z * f.inv_sigma_px,  //
        0.0, 0.0, -f.fb * inv_z * inv_z * f.inv_sigma_d;
  }
  return true;
}

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

/// updatePose's minimisation for ceres::TinySolver (StereoCostLayout::kTinySolver) over the
/// tangent parameters x of TangentPose about the prediction. Rows: the prior (6, linear in x:
/// with the prediction as the base, the rotation change in the predicted body frame is exactly
/// R_p^T theta), 3 per observation robustified inside by the loss (robustify), and one row with a
/// zero Jacobian that carries the rest of Ceres' robust cost. A step that puts an observation
/// behind the camera costs infinity, so the solver rejects it and shrinks its trust region as
/// Ceres does with a failed evaluation.
class TinyPoseProblem {
 public:
  using Scalar = double;
  using Vector6 = Eigen::Matrix<double, 6, 1>;
  using Matrix6 = Eigen::Matrix<double, 6, 6>;
  // NOLINTNEXTLINE(readability-identifier-naming): names fixed by ceres::TinySolver.
  enum { NUM_RESIDUALS = Eigen::Dynamic, NUM_PARAMETERS = 6 };
  static constexpr int kPriorRows = 6;

  TinyPoseProblem(const std::vector<StereoResidual>& residuals,
                  const PoseWithCovariance& prediction,
                  const PoseUpdateOptions& o)
      : residuals_(residuals), T_0_(prediction.T_w_b) {
    R_cl_b_ = residuals.empty() ? Eigen::Matrix3d::Identity() : residuals.front().R_cl_b;
    const PriorResidual prior(prediction, o);  // its sqrt_info and sigmas
    const Eigen::Matrix3d R_p_t = T_0_.linear().transpose();
    Eigen::Matrix<double, 3, 6> planar = Eigen::Matrix<double, 3, 6>::Zero();
    planar(0, 3) = 1.0;                       // dt.x
    planar(1, 4) = 1.0;                       // dt.y
    planar.block<1, 3>(2, 0) = R_p_t.row(2);  // yaw change: (R_p^T theta).z
    prior_jacobian_.setZero();
    prior_jacobian_.topRows<3>() = prior.sqrt_info * planar;
    prior_jacobian_.block<1, 3>(3, 3) = R_p_t.row(2) * prior.inv_sigma_m;    // height change
    prior_jacobian_.block<1, 3>(4, 0) = R_p_t.row(0) * prior.inv_sigma_rad;  // roll change
    prior_jacobian_.block<1, 3>(5, 0) = R_p_t.row(1) * prior.inv_sigma_rad;  // pitch change
  }
  /// The loss of every observation (not owned); null = plain least squares.
  void setLoss(const ceres::LossFunction* loss) { loss_ = loss; }
  // NOLINTNEXTLINE(readability-identifier-naming): ceres::TinySolver's name.
  [[nodiscard]] int NumResiduals() const {
    return kPriorRows + 3 * static_cast<int>(residuals_.size()) + 1;
  }
  /// The pose at x.
  [[nodiscard]] Eigen::Isometry3d pose(const Eigen::Matrix<double, 6, 1>& x) const {
    return TangentPose(T_0_, x, R_cl_b_).T_w_b;
  }
  /// 0.5 |f(x)|^2, the solver's cost; `scratch` holds the residuals.
  [[nodiscard]] double cost(const Eigen::Matrix<double, 6, 1>& x, Eigen::VectorXd* scratch) const {
    scratch->resize(NumResiduals());
    (*this)(x.data(), scratch->data(), nullptr);
    return 0.5 * scratch->squaredNorm();
  }

  /// residuals: NumResiduals(); jacobian: NumResiduals() x 6, column-major (TinySolver's).
  bool operator()(const double* x, double* residuals, double* jacobian) const {
    const int rows = NumResiduals();
    const Eigen::Map<const Eigen::Matrix<double, 6, 1>> xv(x);
    Eigen::Map<Eigen::Matrix<double, 6, 1>> prior_rows(residuals);
    prior_rows = prior_jacobian_ * xv;
    if (jacobian != nullptr) {
      for (int c = 0; c < 6; ++c) {
        for (int i = 0; i < kPriorRows; ++i) jacobian[c * rows + i] = prior_jacobian_(i, c);
      }
    }
    const TangentPose at(T_0_, xv, R_cl_b_);
    double slack = 0.0;
    std::array<double, 18> J{};
    for (size_t k = 0; k < residuals_.size(); ++k) {
      const int row = kPriorRows + 3 * static_cast<int>(k);
      double* r = residuals + row;
      if (!stereoTangentResidual(residuals_[k], at, r, jacobian != nullptr ? J.data() : nullptr)) {
        // Rows not yet written are zeroed so that the cost is exactly infinite (not NaN).
        std::fill(residuals + row, residuals + rows - 1, 0.0);
        residuals[rows - 1] = std::numeric_limits<double>::infinity();
        return true;
      }
      if (loss_ != nullptr)
        slack += robustify(*loss_, r, jacobian != nullptr ? J.data() : nullptr, 6);
      if (jacobian != nullptr) {
        for (int c = 0; c < 6; ++c) {
          for (int i = 0; i < 3; ++i) jacobian[c * rows + row + i] = J[i * 6 + c];
        }
      }
    }
    residuals[rows - 1] = std::sqrt(std::max(0.0, slack));
    if (jacobian != nullptr) {
      for (int c = 0; c < 6; ++c) jacobian[c * rows + rows - 1] = 0.0;
    }
    return true;
  }

  /// |f(x)|^2 over the rows of operator() and, when jtj is given, J^T J and J^T f summed
  /// observation by observation (the n x 6 Jacobian is never stored). Infinite when a step puts
  /// an observation behind the camera.
  ///
  /// An observation's Jacobian (stereoTangentResidual) is J = [D [y]x Jr, -D], D = J_r B_cl_w
  /// (3 x 3), y = p_w - t, Jr the right Jacobian shared by all: the sums are taken in
  /// J' = [D [y]x, -D] and J = J' diag(Jr, I) applied once. J'^T J' has the blocks
  /// ([y]x^T W [y]x, -[y]x^T W; ., W) with W = D^T D, J'^T r = ([y]x^T q; -q) with q = D^T r.
  /// For a loss with rho'' <= 0 (Huber, Cauchy: the ones updatePose uses) Ceres' correction
  /// (robustify) is r_c = sqrt(rho') r, J_c = sqrt(rho') J, so J^T J and J^T r are summed with
  /// the weight rho'; a loss with rho'' > 0, which needs robustify's curvature term, is refused.
  [[nodiscard]] double sumOfSquares(const Vector6& x, Matrix6* jtj, Vector6* jtf) const {
    const Vector6 prior_rows = prior_jacobian_ * x;
    double sum = prior_rows.squaredNorm();
    const TangentPose at(T_0_, x, R_cl_b_);
    const Eigen::Vector3d t = at.T_w_b.translation();
    double slack = 0.0;
    Matrix6 h = Matrix6::Zero();  // J'^T J' weighted; its lower-left block is filled at the end
    Vector6 b = Vector6::Zero();  // J'^T r weighted
    Eigen::Vector3d r;
    Eigen::Matrix3d J_r;
    for (const StereoResidual& f : residuals_) {
      const Eigen::Vector3d y = f.p_w - t;
      const Eigen::Vector3d p_c = at.B_cl_w * y + f.t_cl_b;
      if (!cameraResidual(f, p_c, r.data(), jtj != nullptr ? &J_r : nullptr))
        return std::numeric_limits<double>::infinity();
      const double s = r.squaredNorm();
      double rho1 = 1.0;  // Ceres' corrector as a weight (see above)
      if (loss_ != nullptr) {
        double rho[3];
        loss_->Evaluate(s, rho);
        TWOCAM_CHECK(!(s > 0.0 && rho[2] > 0.0))
            << "the normal-equation pose solve takes losses with rho'' <= 0 only";
        rho1 = rho[1];
        slack += rho[0] - rho1 * s;
      }
      sum += rho1 * s;
      if (jtj == nullptr) continue;
      const Eigen::Matrix3d D = J_r * at.B_cl_w;
      const Eigen::Matrix3d W = D.transpose() * D;
      Eigen::Matrix3d C;  // [y]x^T W: column j is W.col(j) x y
      for (int j = 0; j < 3; ++j) C.col(j) = W.col(j).cross(y);
      Eigen::Matrix3d top_left;  // [y]x^T W [y]x: row i is C.row(i) x y
      for (int i = 0; i < 3; ++i) top_left.row(i) = C.row(i).transpose().cross(y).transpose();
      const Eigen::Vector3d q = D.transpose() * r;
      Vector6 g;
      g << q.cross(y), -q;
      h.topLeftCorner<3, 3>() += rho1 * top_left;
      h.topRightCorner<3, 3>() -= rho1 * C;
      h.bottomRightCorner<3, 3>() += rho1 * W;
      b += rho1 * g;
    }
    if (jtj != nullptr) {
      h.bottomLeftCorner<3, 3>() = h.topRightCorner<3, 3>().transpose();
      const Eigen::Matrix3d& right_jac = at.right_jac;
      jtj->topLeftCorner<3, 3>() = right_jac.transpose() * h.topLeftCorner<3, 3>() * right_jac;
      jtj->topRightCorner<3, 3>() = right_jac.transpose() * h.topRightCorner<3, 3>();
      jtj->bottomLeftCorner<3, 3>() = jtj->topRightCorner<3, 3>().transpose();
      jtj->bottomRightCorner<3, 3>() = h.bottomRightCorner<3, 3>();
      jtf->head<3>() = right_jac.transpose() * b.head<3>();
      jtf->tail<3>() = b.tail<3>();
      *jtj += prior_jacobian_.transpose() * prior_jacobian_;
      *jtf += prior_jacobian_.transpose() * prior_rows;
    }
    return sum + std::max(0.0, slack);  // the last row, squared
  }

 private:
  const std::vector<StereoResidual>& residuals_;
  Eigen::Isometry3d T_0_;
  Eigen::Matrix3d R_cl_b_;
  Eigen::Matrix<double, 6, 6> prior_jacobian_;
  const ceres::LossFunction* loss_ = nullptr;
};

/// The two-stage minimisation (Huber, then Cauchy from there) with ceres::Problem
/// (StereoCostLayout::kOneBlock or kPerObservation); nothing when Ceres finds no usable solution.
std::optional<Eigen::Isometry3d> solveProblem(const std::vector<StereoResidual>& residuals,
                                              const PoseWithCovariance& prediction,
                                              const PoseUpdateOptions& options,
                                              const ceres::LossFunction& huber,
                                              const ceres::LossFunction& cauchy,
                                              StereoCostLayout layout) {
  Eigen::Quaterniond q(prediction.T_w_b.linear());
  q.normalize();
  Eigen::Vector3d t = prediction.T_w_b.translation();
  ceres::LossFunctionWrapper loss(new ceres::HuberLoss(2.0 * options.cauchy_sigma),
                                  ceres::TAKE_OWNERSHIP);
  StereoBatchCost batch(residuals);
  batch.setLoss(&huber);
  // Everything the problem refers to lives on this stack frame: no ownership, no removal.
  ceres::AutoDiffCostFunction<PriorResidual, 6, 4, 3> prior(new PriorResidual(prediction, options));
  std::vector<std::unique_ptr<StereoCost>> per_observation;
  ceres::EigenQuaternionManifold quaternion_manifold;
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.enable_fast_removal = false;
  ceres::Problem problem(po);
  problem.AddParameterBlock(q.coeffs().data(), 4, &quaternion_manifold);
  problem.AddParameterBlock(t.data(), 3);
  problem.AddResidualBlock(&prior, nullptr, q.coeffs().data(), t.data());
  if (layout == StereoCostLayout::kOneBlock) {
    problem.AddResidualBlock(&batch, nullptr, q.coeffs().data(), t.data());
  } else {
    per_observation.reserve(residuals.size());
    for (const StereoResidual& f : residuals) {
      per_observation.push_back(std::make_unique<StereoCost>(f));
      problem.AddResidualBlock(per_observation.back().get(), &loss, q.coeffs().data(), t.data());
    }
  }
  ceres::Solver::Options so;
  // The normal equations of 6 unknowns: 0.75x the time of DENSE_QR at 400 observations
  // (localization_bench), office outputs unchanged.
  so.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  so.max_num_iterations = options.max_iterations;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (summary.IsSolutionUsable()) {
    loss.Reset(new ceres::CauchyLoss(options.cauchy_sigma), ceres::TAKE_OWNERSHIP);
    batch.setLoss(&cauchy);
    ceres::Solve(so, &problem, &summary);
  }
  if (!summary.IsSolutionUsable() || !q.coeffs().allFinite() || !t.allFinite()) return {};
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() = t;
  return T;
}

/// The same two stages with ceres::TinySolver on TinyPoseProblem (StereoCostLayout::kTinySolver).
/// Each stage stops as Ceres' default does: at max_iterations steps, or when a step changes the
/// cost by less than 1e-6 of it (kRelativeFunctionTolerance; TinySolver's tolerance is
/// absolute, so it is set from the stage's starting cost).
std::optional<Eigen::Isometry3d> solveTiny(const std::vector<StereoResidual>& residuals,
                                           const PoseWithCovariance& prediction,
                                           const PoseUpdateOptions& options,
                                           const ceres::LossFunction& huber,
                                           const ceres::LossFunction& cauchy) {
  constexpr double kRelativeFunctionTolerance = 1e-6;
  TinyPoseProblem problem(residuals, prediction, options);
  ceres::TinySolver<TinyPoseProblem> solver;
  // TinySolver counts its iterations from 1 and stops before max_num_iterations.
  solver.options.max_num_iterations = options.max_iterations + 1;
  Eigen::Matrix<double, 6, 1> x = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::VectorXd scratch;
  for (const ceres::LossFunction* loss : {&huber, &cauchy}) {
    problem.setLoss(loss);
    // TinySolver compares 2 x the cost change with the tolerance.
    solver.options.function_tolerance =
        2.0 * kRelativeFunctionTolerance * problem.cost(x, &scratch);
    solver.Solve(problem, &x);
    if (!x.allFinite()) return {};
  }
  return problem.pose(x);
}

/// The same two stages, each minimised by TinySolver's Levenberg-Marquardt (ceres/tiny_solver.h:
/// its Jacobi scaling, trust-region rule and stopping tests, step for step) on the normal
/// equations that TinyPoseProblem::sumOfSquares sums per observation
/// (StereoCostLayout::kNormalEquations). TinySolver forms J^T J from the stored n x 6 Jacobian;
/// this never stores it. Only the summation order differs, so the two agree to rounding.
std::optional<Eigen::Isometry3d> solveNormalEquations(const std::vector<StereoResidual>& residuals,
                                                      const PoseWithCovariance& prediction,
                                                      const PoseUpdateOptions& options,
                                                      const ceres::LossFunction& huber,
                                                      const ceres::LossFunction& cauchy) {
  using Vector6 = TinyPoseProblem::Vector6;
  using Matrix6 = TinyPoseProblem::Matrix6;
  // TinySolver::Options' defaults, and solveTiny's stopping rule (kRelativeFunctionTolerance).
  constexpr double kRelativeFunctionTolerance = 1e-6;
  constexpr double kGradientTolerance = 1e-10;
  constexpr double kParameterTolerance = 1e-8;
  constexpr double kCostThreshold = std::numeric_limits<double>::epsilon();
  constexpr double kInitialTrustRegionRadius = 1e4;
  TinyPoseProblem problem(residuals, prediction, options);
  Vector6 x = Vector6::Zero();
  Matrix6 jtj;
  Vector6 jtf;
  Eigen::LDLT<Matrix6> ldlt;
  for (const ceres::LossFunction* loss : {&huber, &cauchy}) {
    problem.setLoss(loss);
    double sum = problem.sumOfSquares(x, &jtj, &jtf);
    if (!std::isfinite(sum)) return {};
    const double function_tolerance = kRelativeFunctionTolerance * sum;  // 2 x 1e-6 x cost
    // Scaled as TinySolver scales J (columns by 1 / (1 + their norm), fixed at the start).
    const Vector6 scaling = (1.0 + jtj.diagonal().array().sqrt()).inverse().matrix();
    Matrix6 jtj_s = scaling.asDiagonal() * jtj * scaling.asDiagonal();
    Vector6 g = -(scaling.asDiagonal() * jtf);
    double cost = 0.5 * sum;
    if (g.cwiseAbs().maxCoeff() < kGradientTolerance || cost < kCostThreshold) continue;
    double u = 1.0 / kInitialTrustRegionRadius;
    double v = 2.0;
    // TinySolver counts its iterations from 1 and stops before max_num_iterations.
    for (int iteration = 1; iteration <= options.max_iterations; ++iteration) {
      Matrix6 jtj_regularized = jtj_s;
      for (int i = 0; i < 6; ++i) {
        const double lm_diagonal = std::sqrt(u * std::clamp(jtj_s(i, i), 1e-6, 1e32));
        jtj_regularized(i, i) += lm_diagonal * lm_diagonal;
      }
      ldlt.compute(jtj_regularized);
      const Vector6 lm_step = ldlt.solve(g);
      const Vector6 dx = scaling.asDiagonal() * lm_step;
      if (dx.norm() < kParameterTolerance * (x.norm() + kParameterTolerance)) break;
      const Vector6 x_new = x + dx;
      const double cost_change = 2.0 * cost - problem.sumOfSquares(x_new, nullptr, nullptr);
      const double model_cost_change = lm_step.dot(2.0 * g - jtj_s * lm_step);
      const double rho = cost_change / model_cost_change;
      if (rho > 0.0) {
        x = x_new;
        if (std::abs(cost_change) < function_tolerance) break;
        sum = problem.sumOfSquares(x, &jtj, &jtf);
        jtj_s = scaling.asDiagonal() * jtj * scaling.asDiagonal();
        g = -(scaling.asDiagonal() * jtf);
        cost = 0.5 * sum;
        if (g.cwiseAbs().maxCoeff() < kGradientTolerance || cost < kCostThreshold) break;
        const double tmp = 2.0 * rho - 1.0;
        u *= std::max(1.0 / 3.0, 1.0 - tmp * tmp * tmp);
        v = 2.0;
      } else {
        if (std::abs(cost_change) < function_tolerance) break;
        u *= v;
        v *= 2.0;
      }
    }
    if (!x.allFinite()) return {};
  }
  return problem.pose(x);
}

}  // namespace

bool stereoResidualWithJacobians(const StereoResidual& f,
                                 const double* q_w_b,
                                 const double* t_w_b,
                                 double* residual,
                                 double* j_q,
                                 double* j_t) {
  // p_b = conj(q) * (p_w - t) by Eigen's formula for a unit quaternion (x, y, z, w) = (u, w):
  // with a = -u (the conjugate's vector part), p_b = v + 2 w (a x v) + 2 a x (a x v).
  const Eigen::Vector3d u(q_w_b[0], q_w_b[1], q_w_b[2]);
  const double w = q_w_b[3];
  const Eigen::Vector3d v = f.p_w - Eigen::Vector3d(t_w_b[0], t_w_b[1], t_w_b[2]);
  const Eigen::Vector3d a = -u;
  const Eigen::Vector3d axv = a.cross(v);
  const Eigen::Vector3d p_b = v + 2.0 * w * axv + 2.0 * a.cross(axv);
  const Eigen::Vector3d p_c = f.R_cl_b * p_b + f.t_cl_b;
  Eigen::Matrix3d J_r;  // d residual / d p_c
  const bool want_jacobian = j_q != nullptr || j_t != nullptr;
  if (!cameraResidual(f, p_c, residual, want_jacobian ? &J_r : nullptr)) return false;
  if (!want_jacobian) return true;
  const Eigen::Matrix3d J_rb = J_r * f.R_cl_b;  // d residual / d p_b
  if (j_q != nullptr) {
    // d p_b / d a = -2 w [v]x + 2 ((a.v) I + a v^T - 2 v a^T), and d a / d u = -I;
    // d p_b / d w = 2 (a x v).
    Eigen::Matrix3d v_x;
    v_x << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
    const Eigen::Matrix3d d_a =
        -2.0 * w * v_x + 2.0 * (a.dot(v) * Eigen::Matrix3d::Identity() + a * v.transpose() -
                                2.0 * v * a.transpose());
    Eigen::Matrix<double, 3, 4> d_q;
    d_q.leftCols<3>() = -d_a;
    d_q.col(3) = 2.0 * axv;
    Eigen::Map<Eigen::Matrix<double, 3, 4, Eigen::RowMajor>> jq_out(j_q);
    jq_out = J_rb * d_q;
  }
  if (j_t != nullptr) {
    // d p_b / d v = I + 2 w [a]x + 2 [a]x [a]x, and d v / d t = -I.
    Eigen::Matrix3d a_x;
    a_x << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
    const Eigen::Matrix3d d_v = Eigen::Matrix3d::Identity() + 2.0 * w * a_x + 2.0 * a_x * a_x;
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> jt_out(j_t);
    jt_out = -J_rb * d_v;
  }
  return true;
}

TangentPose::TangentPose(const Eigen::Isometry3d& T_0,
                         const Eigen::Matrix<double, 6, 1>& x,
                         const Eigen::Matrix3d& R_cl_b) {
  const Eigen::Vector3d theta = x.head<3>();
  const double a = theta.norm();
  Eigen::Matrix3d exp_theta = Eigen::Matrix3d::Identity();
  if (a > 0.0) exp_theta = Eigen::AngleAxisd(a, theta / a).toRotationMatrix();
  T_w_b = Eigen::Isometry3d::Identity();
  T_w_b.linear() = exp_theta * T_0.linear();
  T_w_b.translation() = T_0.translation() + x.tail<3>();
  B_cl_w = R_cl_b * T_w_b.linear().transpose();
  // Jr(phi) = I - (1 - cos a) / a^2 [phi]x + (a - sin a) / a^3 [phi]x^2 at phi = -theta; its
  // series below 1e-4 rad, where the closed form loses digits.
  const Eigen::Matrix3d K = skew(-theta);
  if (a < 1e-4) {
    right_jac = Eigen::Matrix3d::Identity() - 0.5 * K + K * K / 6.0;
  } else {
    right_jac = Eigen::Matrix3d::Identity() - (1.0 - std::cos(a)) / (a * a) * K +
                (a - std::sin(a)) / (a * a * a) * K * K;
  }
}

bool stereoTangentResidual(const StereoResidual& f,
                           const TangentPose& at,
                           double* residual,
                           double* jacobian) {
  // p_c = R_cl_b R^T (p_w - t) + t_cl_b. With R = Exp(theta) R_0: d(R^T y)/d theta = R^T [y]x
  // Jr(-theta) (Exp(phi + e) = Exp(phi) Exp(Jr(phi) e)), and d y / d dt = -I.
  const Eigen::Vector3d y = f.p_w - at.T_w_b.translation();
  const Eigen::Vector3d p_c = at.B_cl_w * y + f.t_cl_b;
  Eigen::Matrix3d J_r;  // d residual / d p_c
  if (!cameraResidual(f, p_c, residual, jacobian != nullptr ? &J_r : nullptr)) return false;
  if (jacobian == nullptr) return true;
  const Eigen::Matrix3d D = J_r * at.B_cl_w;  // d residual / d y
  Eigen::Map<Eigen::Matrix<double, 3, 6, Eigen::RowMajor>> J(jacobian);
  J.leftCols<3>() = D * skew(y) * at.right_jac;
  J.rightCols<3>() = -D;
  return true;
}

Pose2 toPose2(const Eigen::Isometry3d& T_w_b) {
  const Eigen::Vector3d x_axis = T_w_b.linear().col(0);
  return {T_w_b.translation().x(), T_w_b.translation().y(), std::atan2(x_axis.y(), x_axis.x())};
}

Pose2 odometryIncrement(const Pose2& from, const Pose2& to) {
  const double c = std::cos(from.yaw_rad);
  const double s = std::sin(from.yaw_rad);
  const double dx = to.x_m - from.x_m;
  const double dy = to.y_m - from.y_m;
  return {c * dx + s * dy, -s * dx + c * dy, wrapAngle(to.yaw_rad - from.yaw_rad)};
}

Eigen::Matrix3d odometryCovariance(const OdometryNoise& noise, double path_m, double turn_rad) {
  const OdometryErrorSigma e = accumulatedOdometrySigma(noise, path_m, turn_rad);
  return Eigen::Vector3d(e.trans_m * e.trans_m, e.trans_m * e.trans_m, e.yaw_rad * e.yaw_rad)
      .asDiagonal();
}

PoseWithCovariance predictPose(const PoseWithCovariance& previous,
                               const Pose2& increment,
                               const OdometryNoise& noise) {
  PoseWithCovariance out;
  out.T_w_b = previous.T_w_b * toIsometry(increment);
  const double yaw = toPose2(previous.T_w_b).yaw_rad;
  const Eigen::Vector2d d_w =
      Eigen::Rotation2Dd(yaw) * Eigen::Vector2d(increment.x_m, increment.y_m);
  Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
  F(0, 2) = -d_w.y();
  F(1, 2) = d_w.x();
  const Eigen::Matrix3d G = planarRotation(yaw);
  const Eigen::Matrix3d Q = odometryCovariance(
      noise, std::hypot(increment.x_m, increment.y_m), std::abs(increment.yaw_rad));
  out.cov = F * previous.cov * F.transpose() + G * Q * G.transpose();
  return out;
}

StereoResidual::StereoResidual(const StereoRig& rig,
                               const LandmarkObservation& obs,
                               const PoseUpdateOptions& o)
    : p_w(obs.p_w),
      fx(rig.fx_px),
      fy(rig.fy_px),
      cx(rig.cx_px),
      cy(rig.cy_px),
      fb(rig.fx_px * rig.baseline_m),
      u(obs.u_px),
      v(obs.v_px),
      d(obs.d_px),
      inv_sigma_px(1.0 / o.pixel_sigma_px),
      inv_sigma_d(1.0 / o.disparity_sigma_px) {
  const Eigen::Isometry3d T_cl_b = rig.T_b_cl.inverse();
  R_cl_b = T_cl_b.linear();
  t_cl_b = T_cl_b.translation();
}

PriorResidual::PriorResidual(const PoseWithCovariance& prediction, const PoseUpdateOptions& o)
    : q_p(prediction.T_w_b.linear()),
      t_p(prediction.T_w_b.translation()),
      inv_sigma_m(1.0 / o.planar_sigma_m),
      inv_sigma_rad(1.0 / o.planar_sigma_rad) {
  // A covariance that is (near) singular, e.g. zero at the first frame, is floored so that its
  // information stays finite: 1 mm and 1 mrad.
  Eigen::Matrix3d cov = prediction.cov;
  cov += Eigen::Vector3d(1e-6, 1e-6, 1e-6).asDiagonal();
  const Eigen::Matrix3d info = cov.inverse();
  sqrt_info = info.llt().matrixU();
}

PoseUpdateResult updatePose(const StereoRig& rig,
                            const PoseWithCovariance& prediction,
                            const std::vector<LandmarkObservation>& observations,
                            const PoseUpdateOptions& options) {
  return updatePose(rig, prediction, observations, options, StereoCostLayout::kNormalEquations);
}

PoseUpdateResult updatePose(const StereoRig& rig,
                            const PoseWithCovariance& prediction,
                            const std::vector<LandmarkObservation>& observations,
                            const PoseUpdateOptions& options,
                            StereoCostLayout layout) {
  PoseUpdateResult out;
  out.estimate = prediction;
  out.inlier.assign(observations.size(), 0);
  std::vector<StereoResidual> residuals;
  std::vector<size_t> used;
  residuals.reserve(observations.size());
  const PoseParameters predicted(prediction.T_w_b);
  // The rig's part of every residual, built once (it inverts T_b_cl).
  const StereoResidual common(rig, LandmarkObservation{}, options);
  for (size_t i = 0; i < observations.size(); ++i) {
    StereoResidual f = common;
    f.p_w = observations[i].p_w;
    f.u = observations[i].u_px;
    f.v = observations[i].v_px;
    f.d = observations[i].d_px;
    Eigen::Vector3d r;
    if (!std::isfinite(observations[i].p_w.squaredNorm()) || !(observations[i].d_px > 0.0) ||
        !predicted.residual(f, &r)) {
      continue;
    }
    residuals.push_back(f);
    used.push_back(i);
  }
  out.observations = static_cast<int>(residuals.size());
  if (out.observations < options.min_landmarks) return out;
  if (options.max_observations > 0 &&
      residuals.size() > static_cast<size_t>(options.max_observations)) {
    const size_t n = residuals.size();
    const auto m = static_cast<size_t>(options.max_observations);
    for (size_t k = 0; k < m; ++k) {
      residuals[k] = residuals[k * n / m];
      used[k] = used[k * n / m];
    }
    residuals.erase(residuals.begin() + static_cast<std::ptrdiff_t>(m), residuals.end());
    used.resize(m);
  }

  // Two stages: a Huber loss first, which converges from a prediction many sigma off (a slip),
  // then the redescending Cauchy loss from there, which stops wrong associations pulling.
  const ceres::HuberLoss huber(2.0 * options.cauchy_sigma);
  const ceres::CauchyLoss cauchy(options.cauchy_sigma);
  std::optional<Eigen::Isometry3d> solution =
      layout == StereoCostLayout::kNormalEquations
          ? solveNormalEquations(residuals, prediction, options, huber, cauchy)
      : layout == StereoCostLayout::kTinySolver
          ? solveTiny(residuals, prediction, options, huber, cauchy)
          : solveProblem(residuals, prediction, options, huber, cauchy, layout);
  if (!solution) return out;
  const Eigen::Isometry3d T = *solution;

  // Inliers, and their information on (x, y, yaw): the columns dt.x, dt.y and theta.z of the
  // Jacobian at the solution (theta.z turns the body about the world's vertical).
  const TangentPose at(T, Eigen::Matrix<double, 6, 1>::Zero(), common.R_cl_b);
  Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
  int inliers = 0;
  std::array<double, 18> jacobian{};
  for (size_t k = 0; k < residuals.size(); ++k) {
    Eigen::Vector3d r;
    if (!stereoTangentResidual(residuals[k], at, r.data(), jacobian.data()) ||
        r.squaredNorm() > options.inlier_chi2) {
      continue;
    }
    const Eigen::Map<const Eigen::Matrix<double, 3, 6, Eigen::RowMajor>> J6(jacobian.data());
    Eigen::Matrix3d J;
    J << J6.col(3), J6.col(4), J6.col(2);
    info += J.transpose() * J;
    out.inlier[used[k]] = 1;
    ++inliers;
  }
  out.inliers = inliers;
  if (inliers < options.min_landmarks) {
    out.inlier.assign(observations.size(), 0);
    return out;
  }
  Eigen::Matrix3d prior_cov = prediction.cov;
  prior_cov += Eigen::Vector3d(1e-6, 1e-6, 1e-6).asDiagonal();
  out.estimate.T_w_b = T;
  out.estimate.cov = (prior_cov.inverse() + info).inverse();
  out.visual = true;
  return out;
}

PoseUpdateResult pnpPose(const StereoRig& rig,
                         const PoseWithCovariance& prediction,
                         const std::vector<LandmarkObservation>& observations,
                         const PoseUpdateOptions& update,
                         const PnpOptions& pnp) {
  PoseUpdateResult out;
  out.estimate = prediction;
  out.inlier.assign(observations.size(), 0);
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  std::vector<size_t> used;
  for (size_t i = 0; i < observations.size(); ++i) {
    const LandmarkObservation& o = observations[i];
    if (!o.p_w.allFinite() || !std::isfinite(o.u_px) || !std::isfinite(o.v_px)) continue;
    object.emplace_back(o.p_w.x(), o.p_w.y(), o.p_w.z());
    image.emplace_back(o.u_px, o.v_px);
    used.push_back(i);
  }
  out.observations = static_cast<int>(object.size());
  if (out.observations < std::max(4, update.min_landmarks)) return out;
  const Eigen::Isometry3d T_cl_w = (prediction.T_w_b * rig.T_b_cl).inverse();
  const Eigen::AngleAxisd aa(T_cl_w.linear());
  const Eigen::Vector3d r0 = aa.angle() * aa.axis();
  cv::Mat rvec = (cv::Mat_<double>(3, 1) << r0.x(), r0.y(), r0.z());
  cv::Mat tvec = (cv::Mat_<double>(3, 1) << T_cl_w.translation().x(),
                  T_cl_w.translation().y(),
                  T_cl_w.translation().z());
  const cv::Matx33d K(rig.fx_px, 0, rig.cx_px, 0, rig.fy_px, rig.cy_px, 0, 0, 1);
  cv::Mat inliers;
  bool ok = false;
  try {
    ok = cv::solvePnPRansac(object,
                            image,
                            K,
                            cv::noArray(),
                            rvec,
                            tvec,
                            true,
                            pnp.iterations,
                            static_cast<float>(pnp.reprojection_px),
                            0.99,
                            inliers,
                            cv::SOLVEPNP_ITERATIVE);
  } catch (const cv::Exception&) {
    ok = false;  // degenerate configuration: no visual pose this frame
  }
  if (!ok || inliers.rows < update.min_landmarks) return out;
  Eigen::Vector3d r, t;
  for (int k = 0; k < 3; ++k) {
    r[k] = rvec.at<double>(k);
    t[k] = tvec.at<double>(k);
  }
  if (!r.allFinite() || !t.allFinite()) return out;
  Eigen::Isometry3d T_cl_w_est = Eigen::Isometry3d::Identity();
  if (r.norm() > 0.0) T_cl_w_est.linear() = Eigen::AngleAxisd(r.norm(), r.normalized()).matrix();
  T_cl_w_est.translation() = t;
  out.estimate.T_w_b = T_cl_w_est.inverse() * rig.T_b_cl.inverse();
  out.inliers = inliers.rows;
  for (int k = 0; k < inliers.rows; ++k) out.inlier[used[inliers.at<int>(k)]] = 1;
  out.visual = true;
  return out;
}

double slipChi2(const PoseWithCovariance& start,
                const PoseWithCovariance& end,
                const Pose2& odometry_motion,
                const Eigen::Matrix3d& odometry_cov) {
  const Pose2 visual = odometryIncrement(toPose2(start.T_w_b), toPose2(end.T_w_b));
  const Eigen::Vector3d e(visual.x_m - odometry_motion.x_m,
                          visual.y_m - odometry_motion.y_m,
                          wrapAngle(visual.yaw_rad - odometry_motion.yaw_rad));
  const Eigen::Matrix3d R = planarRotation(toPose2(start.T_w_b).yaw_rad).transpose();
  Eigen::Matrix3d S = odometry_cov + R * (start.cov + end.cov) * R.transpose();
  S += Eigen::Vector3d(1e-8, 1e-8, 1e-8).asDiagonal();
  return e.dot(S.ldlt().solve(e));
}

}  // namespace twocam::localization
