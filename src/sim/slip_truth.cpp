#include "sim/slip_truth.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace twocam::sim {
namespace {

constexpr const char* kHeader = "frame,time_s,dx_m,dy_m,dyaw_deg";

}  // namespace

std::vector<TrueSlip> slipsAtFrameRate(const std::vector<SlipEvent>& events, double frame_rate_hz) {
  std::vector<TrueSlip> out;
  for (const SlipEvent& e : events) {
    out.push_back({static_cast<int32_t>(std::ceil(e.time_s * frame_rate_hz - 1e-9)), e});
  }
  return out;
}

std::vector<TrueSlip> slipsAtTimes(const std::vector<SlipEvent>& events,
                                   const std::vector<int64_t>& t_ns) {
  std::vector<TrueSlip> out;
  for (const SlipEvent& e : events) {
    TrueSlip s{-1, e};
    for (size_t k = 1; k < t_ns.size(); ++k) {
      // As sim::syntheticOdometry: division, exact for whole milliseconds.
      if (e.time_s <= static_cast<double>(t_ns[k] - t_ns[0]) / 1e9) {
        s.frame = static_cast<int32_t>(k);
        break;
      }
    }
    out.push_back(s);
  }
  return out;
}

std::string slipsSidecarPath(const std::string& log_path) {
  const std::filesystem::path p(log_path);
  return ((p.has_parent_path() ? p.parent_path() : std::filesystem::path(".")) /
          (p.stem().string() + ".slips.csv"))
      .string();
}

std::string slipsCsv(const std::vector<TrueSlip>& slips) {
  std::ostringstream csv;
  csv << std::setprecision(9) << kHeader << '\n';
  for (const TrueSlip& s : slips) {
    csv << s.frame << ',' << s.event.time_s << ',' << s.event.dx_m << ',' << s.event.dy_m << ','
        << s.event.dyaw_rad * 180.0 / M_PI << '\n';
  }
  return csv.str();
}

Status parseSlipsCsv(const std::string& text,
                     const std::string& path,
                     std::vector<TrueSlip>* slips) {
  slips->clear();
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  const auto bad = [&](const std::string& why) {
    return Status::error(path + ":" + std::to_string(line_no) + ": " + why);
  };
  if (!std::getline(in, line)) line.clear();
  ++line_no;
  if (!line.empty() && line.back() == '\r') line.pop_back();
  if (line != kHeader) return bad("expected the header '" + std::string(kHeader) + "'");
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    std::vector<std::string> cells;
    std::stringstream row(line);
    std::string cell;
    while (std::getline(row, cell, ',')) cells.push_back(cell);
    if (cells.size() != 5) return bad("expected 5 columns, got " + std::to_string(cells.size()));
    double v[5];
    for (size_t i = 0; i < 5; ++i) {
      size_t used = 0;
      try {
        v[i] = std::stod(cells[i], &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used == 0 || used != cells[i].size() || !std::isfinite(v[i]))
        return bad("'" + cells[i] + "' is not a finite number");
    }
    if (v[0] != std::floor(v[0]) || v[0] < -1.0 || v[0] > 2e9)
      return bad("frame " + cells[0] + ": must be a whole number >= -1");
    if (v[1] < 0.0) return bad("time_s " + cells[1] + ": must be >= 0");
    slips->push_back(
        {static_cast<int32_t>(v[0]), SlipEvent{v[1], v[2], v[3], v[4] * M_PI / 180.0}});
  }
  return Status::ok();
}

Status loadSlipsCsv(const std::string& path, std::vector<TrueSlip>* slips) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return Status::error(path + ": cannot read");
  std::ostringstream s;
  s << f.rdbuf();
  return parseSlipsCsv(s.str(), path, slips);
}

}  // namespace twocam::sim
