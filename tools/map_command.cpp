#include "map_command.h"

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <memory>

#include "store/landmark_store.h"
#include "store/store_export.h"

namespace twocam::tools {

namespace {

int fail(const std::string& sub, std::string message) {
  std::replace(message.begin(), message.end(), '\n', ' ');
  std::cerr << "twocam map " << sub << ": error: " << message << std::endl;
  return 1;
}

std::string formatBytes(int64_t bytes) {
  char text[64];
  if (bytes >= 1024 * 1024) {
    std::snprintf(text,
                  sizeof(text),
                  "%lld bytes (%.1f MiB)",
                  static_cast<long long>(bytes),
                  static_cast<double>(bytes) / (1024.0 * 1024.0));
  } else {
    std::snprintf(text, sizeof(text), "%lld bytes", static_cast<long long>(bytes));
  }
  return text;
}

int runInfo(const MapArgs& args) {
  std::unique_ptr<store::LandmarkStore> map;
  if (Status st = store::LandmarkStore::open(args.map_path, store::OpenMode::kReadOnly, &map);
      !st) {
    return fail("info", st.message());
  }
  store::StoreInfo info;
  if (Status st = map->info(&info); !st) return fail("info", st.message());
  std::cout << "map: " << args.map_path << "\n"
            << "schema version: " << info.schema_version << " (created " << info.created << " by "
            << info.tool_version << ")\n"
            << "file: " << formatBytes(info.file_bytes);
  if (info.wal_bytes > 0) std::cout << " + write-ahead log " << formatBytes(info.wal_bytes);
  std::cout << "\nsessions: " << info.sessions.size() << "\n";
  for (const store::StoredSession& s : info.sessions) {
    std::vector<store::StoredKeyframe> keyframes;
    if (Status st = map->keyframes(s.id, &keyframes); !st) return fail("info", st.message());
    std::cout << "  " << s.id << ": started " << s.started << ", log "
              << (s.log_path.empty() ? std::string("(none)") : s.log_path) << ", "
              << keyframes.size() << " keyframes\n";
  }
  std::cout << "landmarks: " << info.landmark_count << " (next id " << info.next_landmark_id
            << ")\n"
            << "keyframes: " << info.keyframe_count << "\n";
  if (info.landmark_count > 0) {
    char box[256];
    std::snprintf(box,
                  sizeof(box),
                  "bounding box [m]: x %.3f .. %.3f, y %.3f .. %.3f, z %.3f .. %.3f\n",
                  info.box_min_m.x(),
                  info.box_max_m.x(),
                  info.box_min_m.y(),
                  info.box_max_m.y(),
                  info.box_min_m.z(),
                  info.box_max_m.z());
    std::cout << box;
  } else {
    std::cout << "bounding box [m]: none (no landmarks)\n";
  }
  return 0;
}

int runCheck(const MapArgs& args) {
  std::unique_ptr<store::LandmarkStore> map;
  if (Status st = store::LandmarkStore::open(args.map_path, store::OpenMode::kReadOnly, &map);
      !st) {
    return fail("check", st.message());
  }
  if (Status st = map->integrityCheck(); !st) return fail("check", st.message());
  std::cout << args.map_path << ": integrity check ok\n";
  return 0;
}

int runExport(const MapArgs& args) {
  if (args.ply_path.empty() && args.mrpt_path.empty()) {
    return fail("export", "nothing to write: give --ply OUT.ply and/or --mrpt OUT.txt");
  }
  std::unique_ptr<store::LandmarkStore> map;
  if (Status st = store::LandmarkStore::open(args.map_path, store::OpenMode::kReadOnly, &map);
      !st) {
    return fail("export", st.message());
  }
  std::vector<store::StoredLandmark> landmarks;
  if (Status st = map->loadAll(&landmarks); !st) return fail("export", st.message());
  if (!args.ply_path.empty()) {
    const store::PlyFormat format =
        args.ply_ascii ? store::PlyFormat::kAscii : store::PlyFormat::kBinaryLittleEndian;
    if (Status st = store::exportPly(landmarks, args.ply_path, format); !st) {
      return fail("export", st.message());
    }
    std::cout << "wrote " << args.ply_path << ": " << landmarks.size() << " landmarks (PLY)\n";
  }
  if (!args.mrpt_path.empty()) {
    if (Status st = store::exportMrptPointsMap(landmarks, args.mrpt_path); !st) {
      return fail("export", st.message());
    }
    std::cout << "wrote " << args.mrpt_path << ": " << landmarks.size()
              << " landmarks (MRPT CSimplePointsMap text)\n";
  }
  return 0;
}

}  // namespace

MapCommand addMapCommand(CLI::App& app, MapArgs* args) {
  MapCommand c;
  c.map = app.add_subcommand("map", "Inspect or export a landmark store (MAP.db, docs/store.md)");
  c.map->require_subcommand(1);
  c.info = c.map->add_subcommand(
      "info",
      "Print what a map holds: schema version, sessions, landmark and keyframe counts, bounding "
      "box, file size");
  c.info->add_option("map", args->map_path, "Landmark store (SQLite)")->required();
  c.check = c.map->add_subcommand(
      "check",
      "Run SQLite's full PRAGMA integrity_check on a map (read only); exit status 1 when it "
      "fails");
  c.check->add_option("map", args->map_path, "Landmark store (SQLite)")->required();
  c.export_command = c.map->add_subcommand(
      "export", "Write the map's landmarks as a PLY point cloud and/or an MRPT points map");
  c.export_command->add_option("map", args->map_path, "Landmark store (SQLite)")->required();
  c.export_command->add_option(
      "--ply",
      args->ply_path,
      "PLY point cloud (x y z confidence, map frame [m]; MeshLab, CloudCompare)");
  c.export_command->add_flag(
      "--ply-ascii", args->ply_ascii, "Write the PLY as text (default binary)");
  c.export_command->add_option(
      "--mrpt",
      args->mrpt_path,
      "MRPT CSimplePointsMap text file (CPointsMap::load3D_from_text_file reads it)");
  return c;
}

int runMap(const MapCommand& command, const MapArgs& args) {
  if (command.info->parsed()) return runInfo(args);
  if (command.check->parsed()) return runCheck(args);
  if (command.export_command->parsed()) return runExport(args);
  return fail("", "give a subcommand: info, check or export");
}

}  // namespace twocam::tools
