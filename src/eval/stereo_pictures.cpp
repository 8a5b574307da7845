#include "eval/stereo_pictures.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "frontend/cv_interop.h"

namespace twocam::eval {

namespace {

const cv::Scalar kGreen(0, 200, 0);
const cv::Scalar kOrange(0, 150, 255);
const cv::Scalar kRed(0, 0, 230);
const cv::Scalar kYellow(0, 230, 230);
const cv::Scalar kGrey(128, 128, 128);
const cv::Scalar kBlue(230, 120, 0);
const cv::Scalar kBlack(0, 0, 0);
const cv::Scalar kWhite(255, 255, 255);
/// Gap between panels [px], dark so panel edges stay visible.
constexpr int kGapPx = 4;

bool sameSize(int w, int h, const DisparityGroundTruth& gt) {
  return w == gt.d_px.width && h == gt.d_px.height;
}

/// Colour for a disparity in [0, max]: TURBO index 1..255 (0 is kept for "no value" -> black).
cv::Vec3b disparityColour(double d, double max_disp_px, const cv::Mat& lut) {
  const double t = std::clamp(d / max_disp_px, 0.0, 1.0);
  const int index = 1 + static_cast<int>(std::lround(254.0 * t));
  return lut.at<cv::Vec3b>(0, index);
}

/// The 256-entry TURBO palette as a 1x256 BGR row.
cv::Mat turboLut() {
  cv::Mat ramp(1, 256, CV_8UC1);
  for (int i = 0; i < 256; ++i) ramp.at<uint8_t>(0, i) = static_cast<uint8_t>(i);
  cv::Mat lut;
  cv::applyColorMap(ramp, lut, cv::COLORMAP_TURBO);
  return lut;
}

cv::Mat greyToBgr(const ImageU8& image) {
  cv::Mat bgr;
  cv::cvtColor(frontend::asMat(image), bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

/// Text on a dark box so it stays legible over any image; `line` counts from the top
/// (>= 0) or from the bottom (< 0).
void label(cv::Mat* panel, const std::string& text, int line) {
  constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
  constexpr double kScale = 0.38;
  constexpr int kLineHeightPx = 14;
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kFont, kScale, 1, &baseline);
  const int top = line >= 0 ? 2 + line * kLineHeightPx : panel->rows + line * kLineHeightPx - 2;
  cv::rectangle(*panel,
                cv::Rect(0, top, std::min(size.width + 6, panel->cols), kLineHeightPx),
                kBlack,
                cv::FILLED);
  cv::putText(
      *panel, text, cv::Point(3, top + kLineHeightPx - 4), kFont, kScale, kWhite, 1, cv::LINE_AA);
}

cv::Mat joinPanels(const std::vector<cv::Mat>& panels) {
  std::vector<cv::Mat> parts;
  for (size_t i = 0; i < panels.size(); ++i) {
    if (i > 0) parts.emplace_back(panels[i].rows, kGapPx, CV_8UC3, cv::Scalar(40, 40, 40));
    parts.push_back(panels[i]);
  }
  cv::Mat row;
  cv::hconcat(parts, row);
  return row;
}

cv::Mat groundTruthPanel(const DisparityGroundTruth& gt, double max_disp_px, const cv::Mat& lut) {
  cv::Mat panel(gt.d_px.height, gt.d_px.width, CV_8UC3, kBlack);
  for (int v = 0; v < gt.d_px.height; ++v) {
    for (int u = 0; u < gt.d_px.width; ++u) {
      if (gt.valid(u, v) != 0)
        panel.at<cv::Vec3b>(v, u) = disparityColour(gt.d_px(u, v), max_disp_px, lut);
    }
  }
  return panel;
}

std::string fmt(const char* format, double a, double b = 0.0, double c = 0.0) {
  char buf[160];
  std::snprintf(buf, sizeof(buf), format, a, b, c);
  return buf;
}

Status checkMaxDisp(double max_disp_px, const char* who) {
  if (!std::isfinite(max_disp_px) || max_disp_px <= 0.0) {
    return Status::error(std::string(who) + ": max_disp_px = " + std::to_string(max_disp_px) +
                         "; must be finite and > 0");
  }
  return Status::ok();
}

}  // namespace

Status renderDenseEvalPicture(const ImageU8& left,
                              const ImageF32& disparity,
                              const DisparityGroundTruth& gt,
                              double max_disp_px,
                              const StereoEvalOptions& options,
                              cv::Mat* picture,
                              const ImageU8* mask) {
  constexpr const char* kWho = "renderDenseEvalPicture";
  if (Status s = checkMaxDisp(max_disp_px, kWho); !s) return s;
  // Validates options, gt and the disparity size, and gives the summary line.
  StereoMetrics metrics;
  if (Status s = evaluateDense(disparity, gt, mask, options, &metrics); !s) return s;
  if (left.empty() || !sameSize(left.width, left.height, gt) ||
      left.data.size() != gt.d_px.data.size()) {
    return Status::error(std::string(kWho) + ": left image is " + std::to_string(left.width) + "x" +
                         std::to_string(left.height) + ", ground truth is " +
                         std::to_string(gt.d_px.width) + "x" + std::to_string(gt.d_px.height));
  }
  const cv::Mat lut = turboLut();
  const int w = gt.d_px.width;
  const int h = gt.d_px.height;
  cv::Mat left_panel = greyToBgr(left);
  cv::Mat estimate(h, w, CV_8UC3, kBlack);
  cv::Mat errors(h, w, CV_8UC3, kBlack);
  const int b = options.border_px;
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const float d = disparity(u, v);
      const bool has_estimate = d >= 0.0f && std::isfinite(d);
      if (has_estimate) estimate.at<cv::Vec3b>(v, u) = disparityColour(d, max_disp_px, lut);
      const bool evaluated = gt.valid(u, v) != 0 && u >= b && v >= b && u < w - b && v < h - b &&
                             (mask == nullptr || (*mask)(u, v) == 255);
      if (!evaluated) continue;
      cv::Scalar colour = kGrey;
      if (has_estimate) {
        const double err = std::abs(static_cast<double>(d) - gt.d_px(u, v));
        colour = err <= options.bad1_px ? kGreen : err <= options.bad2_px ? kOrange : kRed;
      }
      errors.at<cv::Vec3b>(v, u) = cv::Vec3b(static_cast<uint8_t>(colour[0]),
                                             static_cast<uint8_t>(colour[1]),
                                             static_cast<uint8_t>(colour[2]));
    }
  }
  cv::Mat gt_panel = groundTruthPanel(gt, max_disp_px, lut);
  label(&left_panel, "left", 0);
  label(&estimate, fmt("estimate, 0..%.0f px", max_disp_px), 0);
  label(&gt_panel, fmt("ground truth, 0..%.0f px", max_disp_px), 0);
  label(&errors,
        fmt("error [px]: green<=%.1f orange<=%.1f red>%.1f",
            options.bad1_px,
            options.bad2_px,
            options.bad2_px),
        0);
  label(&errors, "grey none, black not evaluated", 1);
  label(
      &errors,
      fmt("bad1 %.1f%%  bad2 %.1f%%  density %.1f%%", metrics.bad1, metrics.bad2, metrics.density),
      -1);
  *picture = joinPanels({left_panel, estimate, gt_panel, errors});
  return Status::ok();
}

SalientOutcome classifySalientPoint(const StereoHypotheses& hyps,
                                    size_t index,
                                    const DisparityGroundTruth& gt,
                                    const StereoEvalOptions& options) {
  TWOCAM_CHECK(index < hyps.points.size()) << "point " << index << " of " << hyps.points.size();
  const SalientPoint& p = hyps.points[index];
  const int u = p.corner.u_px;
  const int v = p.corner.v_px;
  const int w = gt.d_px.width;
  const int h = gt.d_px.height;
  TWOCAM_CHECK(u >= 0 && v >= 0 && u < w && v < h)
      << "point (" << u << ", " << v << ") outside " << w << "x" << h;
  TWOCAM_CHECK(static_cast<uint64_t>(p.first_hypothesis) + p.num_hypotheses <=
               hyps.hypotheses.size())
      << "hypothesis range of point " << index << " out of bounds";
  const int b = options.border_px;
  if (gt.valid(u, v) == 0 || u < b || v < b || u >= w - b || v >= h - b) {
    return SalientOutcome::kNotEvaluated;
  }
  if (p.num_hypotheses == 0) return SalientOutcome::kNoHypothesis;
  bool best_ok = false;
  bool any_ok = false;
  for (uint32_t j = p.first_hypothesis; j < p.first_hypothesis + p.num_hypotheses; ++j) {
    const DisparityHypothesis& hyp = hyps.hypotheses[j];
    const bool ok = std::isfinite(hyp.d_px) && std::abs(static_cast<double>(hyp.d_px) -
                                                        gt.d_px(u, v)) <= options.recall_tol_px;
    if (ok && hyp.rank == 0) best_ok = true;
    if (ok && hyp.rank < options.k) any_ok = true;
  }
  if (best_ok) return SalientOutcome::kBestCorrect;
  return any_ok ? SalientOutcome::kCorrectWithinK : SalientOutcome::kWrong;
}

Status renderSalientEvalPicture(const ImageU8& left,
                                const StereoHypotheses& hyps,
                                const DisparityGroundTruth& gt,
                                double max_disp_px,
                                const StereoEvalOptions& options,
                                cv::Mat* picture,
                                const ImageU8* mask) {
  constexpr const char* kWho = "renderSalientEvalPicture";
  if (Status s = checkMaxDisp(max_disp_px, kWho); !s) return s;
  // Validates options, gt and every point's hypotheses, and gives the summary line.
  StereoMetrics metrics;
  if (Status s = evaluateSalient(hyps, gt, mask, options, &metrics); !s) return s;
  if (left.empty() || !sameSize(left.width, left.height, gt) ||
      left.data.size() != gt.d_px.data.size()) {
    return Status::error(std::string(kWho) + ": left image is " + std::to_string(left.width) + "x" +
                         std::to_string(left.height) + ", ground truth is " +
                         std::to_string(gt.d_px.width) + "x" + std::to_string(gt.d_px.height));
  }
  const cv::Mat lut = turboLut();
  cv::Mat outcome_panel = greyToBgr(left);
  cv::Mat sparse_panel;
  outcome_panel.convertTo(sparse_panel, -1, 0.35);  // darkened so the dots stand out
  constexpr int kRadiusPx = 3;
  std::array<int, 5> counts{};
  for (size_t i = 0; i < hyps.points.size(); ++i) {
    const SalientPoint& p = hyps.points[i];
    const cv::Point at(p.corner.u_px, p.corner.v_px);
    const SalientOutcome outcome = mask != nullptr && (*mask)(p.corner.u_px, p.corner.v_px) != 255
                                       ? SalientOutcome::kNotEvaluated
                                       : classifySalientPoint(hyps, i, gt, options);
    ++counts[static_cast<size_t>(outcome)];
    const DisparityHypothesis* best = nullptr;
    for (uint32_t j = p.first_hypothesis; j < p.first_hypothesis + p.num_hypotheses; ++j) {
      if (hyps.hypotheses[j].rank == 0) best = &hyps.hypotheses[j];
    }
    cv::Scalar colour = kBlue;
    switch (outcome) {
      case SalientOutcome::kBestCorrect:
        colour = kGreen;
        break;
      case SalientOutcome::kCorrectWithinK:
        colour = kYellow;
        break;
      case SalientOutcome::kWrong:
        colour = kRed;
        break;
      case SalientOutcome::kNoHypothesis:
        colour = kGrey;
        break;
      case SalientOutcome::kNotEvaluated:
        colour = kBlue;
        break;
    }
    const bool filled = best != nullptr && best->lr_consistent;
    cv::circle(outcome_panel, at, kRadiusPx, colour, filled ? cv::FILLED : 1, cv::LINE_8);
    if (best != nullptr && std::isfinite(best->d_px) && best->d_px >= 0.0f) {
      const cv::Vec3b c = disparityColour(best->d_px, max_disp_px, lut);
      cv::circle(sparse_panel,
                 at,
                 kRadiusPx,
                 cv::Scalar(c[0], c[1], c[2]),
                 filled ? cv::FILLED : 1,
                 cv::LINE_8);
    }
  }
  cv::Mat gt_panel = groundTruthPanel(gt, max_disp_px, lut);
  label(&outcome_panel,
        fmt("green best ok %.0f, yellow in top-%.0f %.0f",
            counts[static_cast<size_t>(SalientOutcome::kBestCorrect)],
            options.k,
            counts[static_cast<size_t>(SalientOutcome::kCorrectWithinK)]),
        0);
  label(&outcome_panel,
        fmt("red wrong %.0f, grey none %.0f, blue no GT %.0f",
            counts[static_cast<size_t>(SalientOutcome::kWrong)],
            counts[static_cast<size_t>(SalientOutcome::kNoHypothesis)],
            counts[static_cast<size_t>(SalientOutcome::kNotEvaluated)]),
        1);
  label(&outcome_panel, "filled = best is LR-consistent", -1);
  label(&sparse_panel, fmt("best hypothesis, 0..%.0f px", max_disp_px), 0);
  label(&sparse_panel,
        fmt("bad1 %.1f%%  density %.1f%%  recall@k %.1f%%",
            metrics.bad1,
            metrics.density,
            metrics.recall_at_k),
        -1);
  label(&gt_panel, fmt("ground truth, 0..%.0f px", max_disp_px), 0);
  *picture = joinPanels({outcome_panel, sparse_panel, gt_panel});
  return Status::ok();
}

}  // namespace twocam::eval
