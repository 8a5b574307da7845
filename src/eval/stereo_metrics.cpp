#include "eval/stereo_metrics.h"

#include <cmath>
#include <fstream>
#include <limits>

namespace twocam::eval {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string sizeText(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

Status checkGroundTruth(const DisparityGroundTruth& gt, const char* who) {
  const ImageF32& d = gt.d_px;
  if (d.width <= 0 || d.height <= 0 || d.data.size() != static_cast<size_t>(d.width) * d.height) {
    return Status::error(std::string(who) + ": ground truth is empty or inconsistent");
  }
  if (gt.valid.width != d.width || gt.valid.height != d.height ||
      gt.valid.data.size() != d.data.size()) {
    return Status::error(std::string(who) + ": ground-truth valid mask is " +
                         sizeText(gt.valid.width, gt.valid.height) + ", disparity is " +
                         sizeText(d.width, d.height));
  }
  return Status::ok();
}

Status checkMask(const ImageU8* mask, const DisparityGroundTruth& gt, const char* who) {
  if (mask == nullptr) return Status::ok();
  if (mask->width != gt.d_px.width || mask->height != gt.d_px.height ||
      mask->data.size() != gt.d_px.data.size()) {
    return Status::error(std::string(who) + ": mask is " + sizeText(mask->width, mask->height) +
                         ", ground truth is " + sizeText(gt.d_px.width, gt.d_px.height));
  }
  return Status::ok();
}

/// Whether (u, v) is evaluated: valid ground truth, inside the border frame and the mask.
bool isEvaluated(const DisparityGroundTruth& gt, const ImageU8* mask, int border, int u, int v) {
  const int w = gt.d_px.width;
  const int h = gt.d_px.height;
  if (u < border || v < border || u >= w - border || v >= h - border) return false;
  if (gt.valid(u, v) == 0) return false;
  return mask == nullptr || (*mask)(u, v) == 255;
}

double percent(int64_t count, int64_t total) {
  return total > 0 ? 100.0 * static_cast<double>(count) / static_cast<double>(total) : kNaN;
}

/// Counters shared by both modes.
struct ErrorTally {
  int64_t evaluated = 0;
  int64_t estimated = 0;
  int64_t bad1 = 0;
  int64_t bad2 = 0;
  int64_t bad05 = 0;
  double abs_err_sum = 0.0;

  void addEstimate(double abs_err, const StereoEvalOptions& o) {
    ++estimated;
    abs_err_sum += abs_err;
    bad1 += abs_err > o.bad1_px ? 1 : 0;
    bad2 += abs_err > o.bad2_px ? 1 : 0;
    bad05 += abs_err > o.bad05_px ? 1 : 0;
  }

  void fill(StereoMetrics* m) const {
    m->evaluated = evaluated;
    m->estimated = estimated;
    m->bad1 = percent(bad1, evaluated);
    m->bad2 = percent(bad2, evaluated);
    m->bad05 = percent(bad05, evaluated);
    m->density = percent(estimated, evaluated);
    m->avgerr = estimated > 0 ? abs_err_sum / static_cast<double>(estimated) : kNaN;
  }
};

}  // namespace

Status StereoEvalOptions::validate() const {
  if (border_px < 0)
    return Status::error("border_px = " + std::to_string(border_px) + "; must be >= 0");
  if (!std::isfinite(bad1_px) || bad1_px < 0.0) {
    return Status::error("bad1_px = " + std::to_string(bad1_px) + "; must be finite and >= 0");
  }
  if (!std::isfinite(bad2_px) || bad2_px < 0.0) {
    return Status::error("bad2_px = " + std::to_string(bad2_px) + "; must be finite and >= 0");
  }
  if (!std::isfinite(bad05_px) || bad05_px < 0.0) {
    return Status::error("bad05_px = " + std::to_string(bad05_px) + "; must be finite and >= 0");
  }
  if (k < 1) return Status::error("k = " + std::to_string(k) + "; must be >= 1");
  if (!std::isfinite(recall_tol_px) || recall_tol_px < 0.0) {
    return Status::error("recall_tol_px = " + std::to_string(recall_tol_px) +
                         "; must be finite and >= 0");
  }
  return Status::ok();
}

Status evaluateDense(const ImageF32& disparity,
                     const DisparityGroundTruth& gt,
                     const ImageU8* mask,
                     const StereoEvalOptions& options,
                     StereoMetrics* metrics) {
  constexpr const char* kWho = "evaluateDense";
  if (Status s = options.validate(); !s)
    return Status::error(std::string(kWho) + ": " + s.message());
  if (Status s = checkGroundTruth(gt, kWho); !s) return s;
  if (disparity.width != gt.d_px.width || disparity.height != gt.d_px.height ||
      disparity.data.size() != gt.d_px.data.size()) {
    return Status::error(std::string(kWho) + ": disparity is " +
                         sizeText(disparity.width, disparity.height) + ", ground truth is " +
                         sizeText(gt.d_px.width, gt.d_px.height));
  }
  if (Status s = checkMask(mask, gt, kWho); !s) return s;

  ErrorTally tally;
  int64_t recalled = 0;
  for (int v = 0; v < gt.d_px.height; ++v) {
    for (int u = 0; u < gt.d_px.width; ++u) {
      if (!isEvaluated(gt, mask, options.border_px, u, v)) continue;
      ++tally.evaluated;
      const float d = disparity(u, v);
      if (!(d >= 0.0f) || !std::isfinite(d)) continue;  // < 0 or NaN: no estimate
      const double err = std::abs(static_cast<double>(d) - gt.d_px(u, v));
      tally.addEstimate(err, options);
      recalled += err <= options.recall_tol_px ? 1 : 0;
    }
  }
  StereoMetrics m;
  tally.fill(&m);
  m.k = 1;
  m.recall_at_k = percent(recalled, tally.evaluated);
  m.recall_at_1 = m.recall_at_k;
  m.mean_hypotheses = tally.evaluated > 0 ? static_cast<double>(tally.estimated) /
                                                static_cast<double>(tally.evaluated)
                                          : kNaN;
  m.points = static_cast<int64_t>(disparity.width) * disparity.height;
  *metrics = m;
  return Status::ok();
}

Status tallySalient(const StereoHypotheses& hyps,
                    const DisparityGroundTruth& gt,
                    const ImageU8* mask,
                    const StereoEvalOptions& options,
                    SalientTally* out) {
  constexpr const char* kWho = "evaluateSalient";
  if (Status s = options.validate(); !s)
    return Status::error(std::string(kWho) + ": " + s.message());
  if (Status s = checkGroundTruth(gt, kWho); !s) return s;
  if (Status s = checkMask(mask, gt, kWho); !s) return s;

  ErrorTally tally;
  int64_t recalled_k = 0;
  int64_t recalled_1 = 0;
  int64_t hypotheses_sum = 0;
  int64_t one_answer = 0;
  int64_t one_answer_true = 0;
  const int w = gt.d_px.width;
  const int h = gt.d_px.height;
  for (size_t i = 0; i < hyps.points.size(); ++i) {
    const SalientPoint& p = hyps.points[i];
    const int u = p.corner.u_px;
    const int v = p.corner.v_px;
    if (u < 0 || v < 0 || u >= w || v >= h) {
      return Status::error(std::string(kWho) + ": point " + std::to_string(i) + " at (" +
                           std::to_string(u) + ", " + std::to_string(v) +
                           ") is outside the ground truth's " + sizeText(w, h));
    }
    const uint64_t end = static_cast<uint64_t>(p.first_hypothesis) + p.num_hypotheses;
    if (end > hyps.hypotheses.size()) {
      return Status::error(std::string(kWho) + ": point " + std::to_string(i) +
                           " names hypotheses up to " + std::to_string(end) + ", only " +
                           std::to_string(hyps.hypotheses.size()) + " exist");
    }
    const DisparityHypothesis* best = nullptr;
    bool any_within_k = false;
    // Consistent rivals, to tell an unambiguous best from one of several plausible depths.
    float consistent_min = std::numeric_limits<float>::infinity();
    float consistent_max = -std::numeric_limits<float>::infinity();
    for (uint64_t j = p.first_hypothesis; j < end; ++j) {
      const DisparityHypothesis& hyp = hyps.hypotheses[j];
      if (hyp.point_index != i) {
        return Status::error(std::string(kWho) + ": hypothesis " + std::to_string(j) +
                             " has point_index " + std::to_string(hyp.point_index) +
                             " but lies in point " + std::to_string(i) + "'s range");
      }
      if (hyp.rank == 0) {
        if (best != nullptr) {
          return Status::error(std::string(kWho) + ": point " + std::to_string(i) +
                               " has two rank-0 hypotheses");
        }
        best = &hyp;
      }
      if (hyp.lr_consistent && std::isfinite(hyp.d_px)) {
        consistent_min = std::min(consistent_min, hyp.d_px);
        consistent_max = std::max(consistent_max, hyp.d_px);
      }
      if (hyp.rank < options.k && std::isfinite(hyp.d_px) &&
          std::abs(static_cast<double>(hyp.d_px) - gt.d_px(u, v)) <= options.recall_tol_px) {
        any_within_k = true;
      }
    }
    if (p.num_hypotheses > 0 && best == nullptr) {
      return Status::error(std::string(kWho) + ": point " + std::to_string(i) +
                           " has hypotheses but none of rank 0");
    }
    if (!isEvaluated(gt, mask, options.border_px, u, v)) continue;
    ++tally.evaluated;
    hypotheses_sum += p.num_hypotheses;
    recalled_k += any_within_k ? 1 : 0;
    if (best == nullptr || !std::isfinite(best->d_px)) continue;
    const double err = std::abs(static_cast<double>(best->d_px) - gt.d_px(u, v));
    recalled_1 += err <= options.recall_tol_px ? 1 : 0;
    bool single = true;
    for (uint64_t j = p.first_hypothesis; j < end; ++j) {
      const float d = hyps.hypotheses[j].d_px;
      single = single && std::isfinite(d) &&
               std::abs(static_cast<double>(d) - best->d_px) <= options.recall_tol_px;
    }
    if (single) {
      ++one_answer;
      one_answer_true += err <= options.recall_tol_px ? 1 : 0;
    }
    const bool unambiguous =
        static_cast<double>(consistent_max) - best->d_px <= options.recall_tol_px &&
        static_cast<double>(best->d_px) - consistent_min <= options.recall_tol_px;
    if (best->lr_consistent && unambiguous) tally.addEstimate(err, options);
  }
  SalientTally sum = *out;
  if (sum.k != 0 && sum.k != options.k) {
    return Status::error(std::string(kWho) + ": cannot add k = " + std::to_string(options.k) +
                         " to a tally of k = " + std::to_string(sum.k));
  }
  sum.k = options.k;
  sum.points += static_cast<int64_t>(hyps.points.size());
  sum.evaluated += tally.evaluated;
  sum.estimated += tally.estimated;
  sum.bad1 += tally.bad1;
  sum.bad2 += tally.bad2;
  sum.bad05 += tally.bad05;
  sum.abs_err_sum += tally.abs_err_sum;
  sum.recalled_k += recalled_k;
  sum.recalled_1 += recalled_1;
  sum.hypotheses += hypotheses_sum;
  sum.one_answer += one_answer;
  sum.one_answer_true += one_answer_true;
  *out = sum;
  return Status::ok();
}

StereoMetrics SalientTally::metrics() const {
  ErrorTally tally;
  tally.evaluated = evaluated;
  tally.estimated = estimated;
  tally.bad1 = bad1;
  tally.bad2 = bad2;
  tally.bad05 = bad05;
  tally.abs_err_sum = abs_err_sum;
  StereoMetrics m;
  tally.fill(&m);
  m.k = k;
  m.recall_at_k = percent(recalled_k, evaluated);
  m.recall_at_1 = percent(recalled_1, evaluated);
  m.mean_hypotheses =
      evaluated > 0 ? static_cast<double>(hypotheses) / static_cast<double>(evaluated) : kNaN;
  m.points = points;
  m.one_answer_fraction = percent(one_answer, evaluated);
  m.one_answer_precision = percent(one_answer_true, one_answer);
  return m;
}

Status evaluateSalient(const StereoHypotheses& hyps,
                       const DisparityGroundTruth& gt,
                       const ImageU8* mask,
                       const StereoEvalOptions& options,
                       StereoMetrics* metrics) {
  SalientTally tally;
  if (Status s = tallySalient(hyps, gt, mask, options, &tally); !s) return s;
  *metrics = tally.metrics();
  return Status::ok();
}

void setTiming(double ms, int width_px, int height_px, StereoMetrics* metrics) {
  metrics->ms = ms;
  const double mp = static_cast<double>(width_px) * static_cast<double>(height_px) / 1e6;
  metrics->s_per_mp = width_px > 0 && height_px > 0 ? (ms / 1000.0) / mp : kNaN;
}

io::Json toJsonValue(const StereoMetrics& m) {
  using io::numberOrNull;
  return {{"bad1", numberOrNull(m.bad1)},
          {"bad2", numberOrNull(m.bad2)},
          {"bad0.5", numberOrNull(m.bad05)},
          {"avgerr", numberOrNull(m.avgerr)},
          {"density", numberOrNull(m.density)},
          {"recall_at_k", numberOrNull(m.recall_at_k)},
          {"points", m.points},
          {"ms", numberOrNull(m.ms)},
          {"s_per_mp", numberOrNull(m.s_per_mp)},
          {"k", m.k},
          {"recall_at_1", numberOrNull(m.recall_at_1)},
          {"mean_hypotheses", numberOrNull(m.mean_hypotheses)},
          {"evaluated", m.evaluated},
          {"estimated", m.estimated},
          {"one_answer_fraction", numberOrNull(m.one_answer_fraction)},
          {"one_answer_precision", numberOrNull(m.one_answer_precision)}};
}

std::string toJson(const StereoMetrics& m) {
  std::string text = io::toJsonText(toJsonValue(m), io::kMetricsJsonDigits);
  while (!text.empty() && text.back() == '\n') text.pop_back();
  return text;
}

Status writeJson(const std::string& path, const StereoMetrics& metrics) {
  std::ofstream f(path, std::ios::trunc);
  if (!f) return Status::error(path + ": cannot open for writing");
  f << toJson(metrics) << '\n';
  f.flush();
  if (!f) return Status::error(path + ": write failed");
  return Status::ok();
}

}  // namespace twocam::eval
