#include "store/store_export.h"

#include <mrpt/maps/CSimplePointsMap.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>

namespace twocam::store {

namespace fs = std::filesystem;

namespace {

/// A temporary name beside `path` (same folder, so the rename is atomic).
std::string temporaryPath(const std::string& path) {
  return path + ".tmp-" + std::to_string(::getpid());
}

/// Renames `tmp` onto `path`, or removes it and returns the error.
Status commitFile(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    return Status::error("cannot write '" + path + "': rename failed");
  }
  return Status::ok();
}

void writeLittleEndian(std::ostream& out, const void* value, size_t bytes) {
  // Every platform we build for is little-endian (static_assert below).
  out.write(static_cast<const char*>(value), static_cast<std::streamsize>(bytes));
}

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "PLY writer assumes little-endian");

}  // namespace

Status exportPly(const std::vector<StoredLandmark>& landmarks,
                 const std::string& path,
                 PlyFormat format) {
  const std::string tmp = temporaryPath(path);
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return Status::error("cannot write '" + path + "' (cannot create '" + tmp + "')");
    out << "ply\n"
        << (format == PlyFormat::kAscii ? "format ascii 1.0\n"
                                        : "format binary_little_endian 1.0\n")
        << "comment TwoCam landmark store export: confirmed landmarks in the map frame [m]\n"
        << "element vertex " << landmarks.size() << "\n"
        << "property double x\nproperty double y\nproperty double z\n"
        << "property float confidence\n"
        << "end_header\n";
    if (format == PlyFormat::kAscii) {
      out << std::setprecision(17);
      for (const StoredLandmark& l : landmarks) {
        out << l.p_m.x() << ' ' << l.p_m.y() << ' ' << l.p_m.z() << ' ' << std::setprecision(9)
            << static_cast<float>(l.confidence) << std::setprecision(17) << '\n';
      }
    } else {
      for (const StoredLandmark& l : landmarks) {
        writeLittleEndian(out, l.p_m.data(), sizeof(double) * 3);
        const float confidence = static_cast<float>(l.confidence);
        writeLittleEndian(out, &confidence, sizeof(confidence));
      }
    }
    out.flush();
    if (!out) {
      out.close();
      std::error_code ec;
      fs::remove(tmp, ec);
      return Status::error("cannot write '" + path + "' (write failed)");
    }
  }
  return commitFile(tmp, path);
}

Status exportPly(const LandmarkStore& store, const std::string& path, PlyFormat format) {
  std::vector<StoredLandmark> landmarks;
  if (Status st = store.loadAll(&landmarks); !st) return st;
  return exportPly(landmarks, path, format);
}

Status exportMrptPointsMap(const std::vector<StoredLandmark>& landmarks, const std::string& path) {
  mrpt::maps::CSimplePointsMap map;
  map.reserve(landmarks.size());
  for (const StoredLandmark& l : landmarks) {
    map.insertPoint(static_cast<float>(l.p_m.x()),
                    static_cast<float>(l.p_m.y()),
                    static_cast<float>(l.p_m.z()));
  }
  const std::string tmp = temporaryPath(path);
  if (!map.save3D_to_text_file(tmp)) {
    std::error_code ec;
    fs::remove(tmp, ec);
    return Status::error("cannot write '" + path + "' (cannot create '" + tmp + "')");
  }
  return commitFile(tmp, path);
}

Status exportMrptPointsMap(const LandmarkStore& store, const std::string& path) {
  std::vector<StoredLandmark> landmarks;
  if (Status st = store.loadAll(&landmarks); !st) return st;
  return exportMrptPointsMap(landmarks, path);
}

}  // namespace twocam::store
