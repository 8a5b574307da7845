#pragma once
/// `twocam map info MAP.db`, `twocam map check MAP.db` and `twocam map export MAP.db
/// [--ply OUT.ply] [--mrpt OUT.txt]`: what a landmark store holds, whether it passes SQLite's
/// full integrity check, and its landmarks in formats other tools read (docs/store.md). All open
/// the store read-only: the map is never modified.

#include <CLI/CLI.hpp>
#include <string>

namespace twocam::tools {

struct MapArgs {
  /// The store (SQLite file written by the landmark store).
  std::string map_path;
  /// `export`: PLY point cloud path ("" = none); --ply-ascii writes it as text.
  std::string ply_path;
  bool ply_ascii = false;
  /// `export`: MRPT CSimplePointsMap text file path ("" = none).
  std::string mrpt_path;
};

/// The parsed `map` command and which of its subcommands ran.
struct MapCommand {
  CLI::App* map = nullptr;
  CLI::App* info = nullptr;
  CLI::App* check = nullptr;
  CLI::App* export_command = nullptr;
};

/// Registers `map` with its `info`, `check` and `export` subcommands on `app`, parsing into *args.
MapCommand addMapCommand(CLI::App& app, MapArgs* args);

/// Runs the parsed subcommand. Returns the exit code (0 ok, 1 error: for `check`, a store that
/// cannot be opened or fails the integrity check); an error is one line
/// "twocam map <sub>: error: ..." naming the path, on stderr.
int runMap(const MapCommand& command, const MapArgs& args);

}  // namespace twocam::tools
