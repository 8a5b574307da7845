#include "mapping/occupancy_mapper.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "support/test_paths.h"

namespace twocam::mapping {
namespace {

namespace fs = std::filesystem;

/// OctoMap stores log-odds as float: probabilities agree to float precision.
constexpr double kProbabilityTol = 1e-5;
/// Voxel centres come from integer keys times the resolution, in double.
constexpr double kCentreTol = 1e-9;

MappingOptions defaultOptions() { return MappingOptions{}; }

/// Centre of the voxel holding p at resolution r: OctoMap's key is floor(p / r) + 2^15.
Eigen::Vector3d voxelCentre(const Eigen::Vector3d& p, double r) {
  return Eigen::Vector3d((std::floor(p.x() / r) + 0.5) * r,
                         (std::floor(p.y() / r) + 0.5) * r,
                         (std::floor(p.z() / r) + 0.5) * r);
}

/// Probability of the finest voxel holding p, or NaN when the tree knows nothing there.
double probabilityAt(const OccupancyMapper& mapper, const Eigen::Vector3d& p) {
  const octomap::OcTreeNode* node = mapper.tree().search(p.x(), p.y(), p.z());
  return node == nullptr ? std::numeric_limits<double>::quiet_NaN() : node->getOccupancy();
}

double logit(double p) { return std::log(p / (1.0 - p)); }
double sigmoid(double l) { return 1.0 / (1.0 + std::exp(-l)); }

TEST(MappingOptions, LimitWordingNamesKeyValueAndRange) {
  MappingOptions o = defaultOptions();
  o.resolution_m = 0.001;
  EXPECT_EQ(o.validate().message(), "mapping.resolution_m = 0.001; must be in [0.02, 10] [m]");
}

TEST(MappingOptions, DefaultsAreValid) { EXPECT_TRUE(defaultOptions().validate().isOk()); }

TEST(MappingOptions, RejectsBadValuesNamingTheField) {
  struct Case {
    const char* field;
    void (*apply)(MappingOptions*);
  };
  const Case cases[] = {
      {"resolution_m", [](MappingOptions* o) { o->resolution_m = 0.0; }},
      {"resolution_m", [](MappingOptions* o) { o->resolution_m = std::nan(""); }},
      {"max_range_m", [](MappingOptions* o) { o->max_range_m = -1.0; }},
      {"max_range_m",
       [](MappingOptions* o) { o->max_range_m = 5000.0; }},  // beyond the octree at 5 cm
      // Costs the map cannot honour (0.001 m exhausted memory on the office log).
      {"resolution_m", [](MappingOptions* o) { o->resolution_m = 0.001; }},
      {"resolution_m", [](MappingOptions* o) { o->resolution_m = 100.0; }},
      {"max_range_m", [](MappingOptions* o) { o->max_range_m = 200.0; }},
      {"max_range_m", [](MappingOptions* o) { o->max_range_m = 60.0; }},  // 1200 voxels a ray
      {"prob_hit", [](MappingOptions* o) { o->prob_hit = 1.0; }},
      {"prob_hit", [](MappingOptions* o) { o->prob_hit = 0.45; }},
      {"prob_miss", [](MappingOptions* o) { o->prob_miss = 0.0; }},
      {"prob_miss", [](MappingOptions* o) { o->prob_miss = 0.6; }},
      {"clamp_min", [](MappingOptions* o) { o->clamp_min = 0.0; }},
      {"clamp_min", [](MappingOptions* o) { o->clamp_min = 0.6; }},
      {"clamp_max", [](MappingOptions* o) { o->clamp_max = 1.0; }},
      {"clamp_max", [](MappingOptions* o) { o->clamp_max = 0.45; }},
      {"occupied_threshold", [](MappingOptions* o) { o->occupied_threshold = 1.5; }},
  };
  for (const Case& c : cases) {
    MappingOptions o = defaultOptions();
    c.apply(&o);
    const Status st = o.validate();
    ASSERT_FALSE(st.isOk()) << c.field;
    EXPECT_NE(st.message().find(c.field), std::string::npos) << st.message();
  }
}

TEST(OccupancyMapperDeathTest, RejectsInvalidOptions) {
  MappingOptions o;
  o.resolution_m = -0.05;
  EXPECT_DEATH(OccupancyMapper mapper(o), "resolution_m");
}

TEST(OccupancyMapper, RepeatedPointBecomesOccupiedAtItsVoxel) {
  const MappingOptions o = defaultOptions();
  OccupancyMapper mapper(o);
  const Eigen::Vector3d p(2.013, 0.512, 0.337);
  for (int frame = 0; frame < 5; ++frame) mapper.insertFrame(Eigen::Vector3d::Zero(), {p});
  const std::vector<Voxel> voxels = mapper.occupiedVoxels();
  ASSERT_EQ(voxels.size(), 1U);
  const Eigen::Vector3d expected = voxelCentre(p, o.resolution_m);
  EXPECT_NEAR((voxels[0].centre_m - expected).norm(), 0.0, kCentreTol);
  EXPECT_DOUBLE_EQ(voxels[0].size_m, o.resolution_m);
  // Five hits: logit 5 * logit(0.7) exceeds the clamp, so the voxel sits at clamp_max.
  EXPECT_NEAR(voxels[0].probability, o.clamp_max, kProbabilityTol);
  EXPECT_EQ(mapper.stats().frames, 5);
  EXPECT_EQ(mapper.stats().points_inserted, 5);
}

TEST(OccupancyMapper, VoxelsAlongTheRayBecomeFree) {
  const MappingOptions o = defaultOptions();
  OccupancyMapper mapper(o);
  const Eigen::Vector3d origin(0.01, 0.02, 0.03);
  const Eigen::Vector3d p(3.01, 0.02, 0.03);
  mapper.insertFrame(origin, {p});
  for (const double x : {0.5, 1.0, 1.5, 2.0, 2.9}) {
    const double prob = probabilityAt(mapper, Eigen::Vector3d(x, 0.02, 0.03));
    ASSERT_FALSE(std::isnan(prob)) << "x = " << x;
    EXPECT_NEAR(prob, o.prob_miss, kProbabilityTol) << "x = " << x;
    EXPECT_LT(prob, 0.5);
  }
  EXPECT_NEAR(probabilityAt(mapper, p), o.prob_hit, kProbabilityTol);
  // Nothing beyond the landmark.
  EXPECT_TRUE(std::isnan(probabilityAt(mapper, Eigen::Vector3d(3.2, 0.02, 0.03))));
}

TEST(OccupancyMapper, OneUpdatePerVoxelPerFrameAndHitWinsOverMiss) {
  const MappingOptions o = defaultOptions();
  OccupancyMapper mapper(o);
  const Eigen::Vector3d origin(0.01, 0.01, 0.01);
  // Three landmarks in one voxel, and a farther one whose ray crosses the first voxel.
  const Eigen::Vector3d near_a(1.011, 0.011, 0.011);
  const Eigen::Vector3d near_b(1.021, 0.021, 0.021);
  const Eigen::Vector3d near_c(1.031, 0.031, 0.031);
  const Eigen::Vector3d far(2.011, 0.011, 0.011);
  ASSERT_EQ(voxelCentre(near_a, o.resolution_m), voxelCentre(near_c, o.resolution_m));
  mapper.insertFrame(origin, {near_a, far, near_b, near_c});
  // One hit, not three, and the miss from the far ray lost to the hit.
  EXPECT_NEAR(probabilityAt(mapper, near_a), o.prob_hit, kProbabilityTol);
  // Voxels crossed by both rays got one miss.
  EXPECT_NEAR(
      probabilityAt(mapper, Eigen::Vector3d(0.5, 0.011, 0.011)), o.prob_miss, kProbabilityTol);
  EXPECT_NEAR(probabilityAt(mapper, far), o.prob_hit, kProbabilityTol);
  EXPECT_EQ(mapper.stats().last_frame_hits, 2);
  EXPECT_EQ(mapper.stats().points_inserted, 4);
}

TEST(OccupancyMapper, SpuriousPointSeenThroughFromOtherViewpointsEndsFree) {
  const MappingOptions o = defaultOptions();
  OccupancyMapper mapper(o);
  // A false landmark at a voxel centre, observed once.
  const Eigen::Vector3d spurious(2.025, 0.025, 0.025);
  mapper.insertFrame(Eigen::Vector3d(0.0, 0.0, 0.0), {spurious});
  ASSERT_EQ(mapper.occupiedVoxels().size(), 1U);
  // Later frames from other viewpoints see a wall point behind it, on a ray through it.
  std::vector<Eigen::Vector3d> wall_points;
  for (const double y : {-0.3, -0.1, 0.1, 0.3}) {
    const Eigen::Vector3d origin(0.0, y, 0.0);
    const Eigen::Vector3d wall = spurious + (spurious - origin);  // ray passes through spurious
    wall_points.push_back(wall);
    mapper.insertFrame(origin, {wall});
  }
  // 1 hit, 4 misses: logit(0.7) + 4 logit(0.4) < 0.
  const double expected = sigmoid(logit(o.prob_hit) + 4.0 * logit(o.prob_miss));
  EXPECT_NEAR(probabilityAt(mapper, spurious), expected, kProbabilityTol);
  EXPECT_LT(probabilityAt(mapper, spurious), o.occupied_threshold);
  const std::vector<Voxel> voxels = mapper.occupiedVoxels();
  EXPECT_EQ(voxels.size(), wall_points.size());
  for (const Voxel& v : voxels) {
    EXPECT_GT((v.centre_m - spurious).norm(), o.resolution_m);
  }
}

TEST(OccupancyMapper, PointsBeyondRangeOrNonFiniteAreIgnored) {
  const MappingOptions o = defaultOptions();
  OccupancyMapper mapper(o);
  const Eigen::Vector3d far(o.max_range_m + 0.5, 0.01, 0.01);
  const Eigen::Vector3d nan_point(std::nan(""), 0.0, 0.0);
  const Eigen::Vector3d inf_point(1.0, std::numeric_limits<double>::infinity(), 0.0);
  const Eigen::Vector3d good(1.01, 0.51, 0.01);
  mapper.insertFrame(Eigen::Vector3d::Zero(), {far, nan_point, good, inf_point});
  EXPECT_EQ(mapper.stats().points_beyond_range, 1);
  EXPECT_EQ(mapper.stats().points_invalid, 2);
  EXPECT_EQ(mapper.stats().points_inserted, 1);
  // Neither the far point's voxel nor its ray were touched.
  EXPECT_TRUE(std::isnan(probabilityAt(mapper, far)));
  EXPECT_TRUE(std::isnan(probabilityAt(mapper, Eigen::Vector3d(3.0, 0.01, 0.01))));
  ASSERT_EQ(mapper.occupiedVoxels().size(), 1U);
}

TEST(OccupancyMapper, WithoutFreeSpaceOnlyEndVoxelsAreUpdated) {
  MappingOptions o = defaultOptions();
  o.insert_free_space = false;
  OccupancyMapper mapper(o);
  const Eigen::Vector3d p(3.01, 0.02, 0.03);
  mapper.insertFrame(Eigen::Vector3d::Zero(), {p});
  EXPECT_NEAR(probabilityAt(mapper, p), o.prob_hit, kProbabilityTol);
  EXPECT_TRUE(std::isnan(probabilityAt(mapper, Eigen::Vector3d(1.5, 0.02, 0.03))));
  EXPECT_EQ(mapper.stats().last_frame_misses, 0);
}

std::vector<Eigen::Vector3d> randomPoints(std::mt19937& rng, int n) {
  std::uniform_real_distribution<double> range(1.0, 6.0);
  std::normal_distribution<double> dir(0.0, 1.0);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < n; ++i) {
    // named draws: a call's arguments are evaluated in an unspecified order (GCC's, right to left,
    // kept)
    const double dz = dir(rng);
    const double dy = dir(rng);
    const double dx = dir(rng);
    const Eigen::Vector3d d = Eigen::Vector3d(dx, dy, dz).normalized();
    points.push_back(range(rng) * d);
  }
  return points;
}

/// The mapper's sensor model and clamping on an OctoMap tree built as the reference.
void setSensorModel(const MappingOptions& o, octomap::OcTree* tree) {
  tree->setProbHit(o.prob_hit);
  tree->setProbMiss(o.prob_miss);
  tree->setClampingThresMin(o.clamp_min);
  tree->setClampingThresMax(o.clamp_max);
  tree->setOccupancyThres(o.occupied_threshold);
}

/// OctoMap's own per-key path (updateNode(key, occupied, lazy_eval = false)) with the same
/// sensor model: one ray per distinct end voxel, to the first point in it; hit wins over miss.
void referenceInsert(octomap::OcTree* tree,
                     const Eigen::Vector3d& origin_w,
                     const std::vector<Eigen::Vector3d>& points_w,
                     double max_range_m) {
  const octomap::point3d origin(static_cast<float>(origin_w.x()),
                                static_cast<float>(origin_w.y()),
                                static_cast<float>(origin_w.z()));
  octomap::KeySet occupied;
  octomap::KeySet free;
  octomap::KeyRay ray;
  for (const Eigen::Vector3d& p : points_w) {
    if ((p - origin_w).norm() > max_range_m) continue;
    const octomap::point3d end(
        static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
    const octomap::OcTreeKey key = tree->coordToKey(end);
    if (!occupied.insert(key).second) continue;
    if (tree->computeRayKeys(origin, end, ray)) free.insert(ray.begin(), ray.end());
  }
  for (const octomap::OcTreeKey& k : free) {
    if (occupied.count(k) == 0) tree->updateNode(k, false, false);
  }
  for (const octomap::OcTreeKey& k : occupied) tree->updateNode(k, true, false);
}

/// Number of known finest voxels (pruned leaves count for all the voxels they cover) that are
/// free by OctoMap's rule.
int64_t freeVoxelCount(const octomap::OcTree& tree) {
  int64_t n = 0;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) {
    if (!tree.isNodeOccupied(*it)) n += int64_t{1} << (3U * (tree.getTreeDepth() - it.getDepth()));
  }
  return n;
}

TEST(OccupancyMapper, BatchedUpdateMatchesOctomapPerKeyUpdates) {
  const MappingOptions o = defaultOptions();
  OccupancyMapper mapper(o);
  octomap::OcTree reference(o.resolution_m);
  setSensorModel(o, &reference);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> across(-1.0, 1.0);
  std::uniform_real_distribution<double> depth(0.5, 7.0);
  for (int frame = 0; frame < 40; ++frame) {
    // A robot creeping towards a wall at x = 3 m, seeing wall points and some outliers; the
    // many repeated rays clamp free space, so pruned cubes get expanded and re-pruned.
    const Eigen::Vector3d origin(0.01 * frame, 0.02, 0.3);
    std::vector<Eigen::Vector3d> points;
    for (int i = 0; i < 120; ++i) points.emplace_back(3.0, across(rng), 0.3 + across(rng));
    for (int i = 0; i < 30; ++i)
      points.push_back(origin +
                       depth(rng) *
                           Eigen::Vector3d(1.0, 0.5 * across(rng), 0.4 * across(rng)).normalized());
    mapper.insertFrame(origin, points);
    referenceInsert(&reference, origin, points, o.max_range_m);
  }
  const std::vector<Voxel> got = mapper.occupiedVoxels();
  const std::vector<Voxel> expected = occupiedVoxels(reference);
  ASSERT_GT(expected.size(), 1000U);
  ASSERT_EQ(got.size(), expected.size());
  for (size_t i = 0; i < got.size(); ++i) {
    ASSERT_EQ(got[i].centre_m, expected[i].centre_m) << i;
    ASSERT_EQ(got[i].probability, expected[i].probability) << i;
  }
  int pruned_leaves = 0;  // the comparison covers expanding and re-pruning
  for (auto it = mapper.tree().begin_leafs(); it != mapper.tree().end_leafs(); ++it) {
    pruned_leaves += it.getDepth() < mapper.tree().getTreeDepth() ? 1 : 0;
  }
  ASSERT_GT(pruned_leaves, 0);
  const int64_t free_voxels = freeVoxelCount(reference);
  ASSERT_GT(free_voxels, 10000);
  EXPECT_EQ(freeVoxelCount(mapper.tree()), free_voxels);
  // Every voxel either tree knows has the same log-odds in the other.
  const octomap::OcTree* const trees[2] = {&reference, &mapper.tree()};
  for (int i = 0; i < 2; ++i) {
    const octomap::OcTree* a = trees[i];
    const octomap::OcTree* b = trees[1 - i];
    for (auto it = a->begin_leafs(); it != a->end_leafs(); ++it) {
      const octomap::OcTreeNode* other = b->search(it.getKey(), it.getDepth());
      ASSERT_NE(other, nullptr);
      ASSERT_EQ(other->getLogOdds(), it->getLogOdds());
    }
  }
}

/// Expects every leaf of either tree at the same depth and log-odds in the other.
void expectSameLeaves(const octomap::OcTree& a, const octomap::OcTree& b) {
  const octomap::OcTree* const trees[2] = {&a, &b};
  for (int i = 0; i < 2; ++i) {
    const octomap::OcTree* x = trees[i];
    const octomap::OcTree* y = trees[1 - i];
    for (auto it = x->begin_leafs(); it != x->end_leafs(); ++it) {
      const octomap::OcTreeNode* other = y->search(it.getKey(), it.getDepth());
      ASSERT_NE(other, nullptr);
      ASSERT_EQ(y->nodeHasChildren(other), false);
      ASSERT_EQ(other->getLogOdds(), it->getLogOdds());
    }
  }
  EXPECT_EQ(a.size(), b.size());
}

TEST(OccupancyMapper, BatchedUpdateMatchesOctomapAcrossKeyBoundariesAndLongRays) {
  // insertFrame sorts a frame's updates by codes that fit its key range (voxel_codes.h): 27-bit
  // codes when the rays span less than 256 voxels per axis (max_range_m = 6 m), Morton codes
  // otherwise (12 m). Origins sit where keys cross multiples of 2^15 (the world origin), 2^8
  // and 2^11, where the two layouts' orders are easiest to get wrong.
  const Eigen::Vector3d origins[] = {
      {0.01, 0.02, 0.03}, {12.8, -0.01, 0.3}, {-12.81, 102.4, -0.02}, {6.4, 6.4, 6.4}};
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> across(-0.3, 0.3);
  for (const double max_range_m : {6.0, 12.0}) {
    MappingOptions o = defaultOptions();
    o.max_range_m = max_range_m;
    OccupancyMapper mapper(o);
    octomap::OcTree reference(o.resolution_m);
    setSensorModel(o, &reference);
    for (const Eigen::Vector3d& base : origins) {
      for (int frame = 0; frame < 8; ++frame) {
        const Eigen::Vector3d origin =
            base + Eigen::Vector3d(across(rng), across(rng), across(rng));
        std::vector<Eigen::Vector3d> points = randomPoints(rng, 150);
        for (Eigen::Vector3d& p : points) p = origin + p * (max_range_m / 6.0);
        mapper.insertFrame(origin, points);
        referenceInsert(&reference, origin, points, o.max_range_m);
      }
    }
    SCOPED_TRACE("max_range_m " + std::to_string(max_range_m));
    ASSERT_GT(reference.size(), 10000U);
    expectSameLeaves(mapper.tree(), reference);
  }
}

TEST(OccupancyMapper, OccupiedVoxelsAreSortedAndRepeatable) {
  const MappingOptions o = defaultOptions();
  OccupancyMapper a(o);
  OccupancyMapper b(o);
  std::mt19937 rng(7);
  for (int frame = 0; frame < 5; ++frame) {
    const std::vector<Eigen::Vector3d> points = randomPoints(rng, 150);
    a.insertFrame(Eigen::Vector3d::Zero(), points);
    b.insertFrame(Eigen::Vector3d::Zero(), points);
  }
  const std::vector<Voxel> va = a.occupiedVoxels();
  const std::vector<Voxel> vb = b.occupiedVoxels();
  ASSERT_GT(va.size(), 100U);
  ASSERT_EQ(va.size(), vb.size());
  const auto less = [](const Voxel& l, const Voxel& r) {
    return std::lexicographical_compare(
        l.centre_m.data(), l.centre_m.data() + 3, r.centre_m.data(), r.centre_m.data() + 3);
  };
  EXPECT_TRUE(std::is_sorted(va.begin(), va.end(), less));
  for (size_t i = 0; i < va.size(); ++i) {
    ASSERT_EQ(va[i].centre_m, vb[i].centre_m) << i;
    ASSERT_EQ(va[i].probability, vb[i].probability) << i;
  }
}

TEST(OccupancyMapper, PrunedLeavesAreExpandedToFinestVoxels) {
  MappingOptions o = defaultOptions();
  o.insert_free_space = false;
  OccupancyMapper mapper(o);
  // The 8 voxels of one aligned 10 cm cell (keys 2k, 2k+1 on each axis), driven to clamp_max.
  std::vector<Eigen::Vector3d> block;
  for (const double x : {1.025, 1.075}) {
    for (const double y : {0.025, 0.075}) {
      for (const double z : {0.025, 0.075}) block.emplace_back(x, y, z);
    }
  }
  for (int frame = 0; frame < 10; ++frame) mapper.insertFrame(Eigen::Vector3d::Zero(), block);
  // OctoMap merged them into one coarser leaf...
  int occupied_leaves = 0;
  for (auto it = mapper.tree().begin_leafs(); it != mapper.tree().end_leafs(); ++it) {
    if (mapper.tree().isNodeOccupied(*it)) {
      ++occupied_leaves;
      EXPECT_LT(it.getDepth(), mapper.tree().getTreeDepth());
    }
  }
  ASSERT_EQ(occupied_leaves, 1);
  // ...which occupiedVoxels reports as the 8 voxels.
  const std::vector<Voxel> voxels = mapper.occupiedVoxels();
  ASSERT_EQ(voxels.size(), 8U);
  for (size_t i = 0; i < voxels.size(); ++i) {
    EXPECT_NEAR((voxels[i].centre_m - block[i]).norm(), 0.0, kCentreTol) << i;
  }
}

TEST(OccupancyMapper, WriteBinaryRoundTripsAndReplacesAnExistingFile) {
  const std::string dir = test::makeTempDir("mapping_write_binary");
  const std::string path = dir + "/map.bt";
  const MappingOptions o = defaultOptions();
  std::mt19937 rng(11);

  OccupancyMapper first(o);
  first.insertFrame(Eigen::Vector3d::Zero(), randomPoints(rng, 20));
  ASSERT_TRUE(first.writeBinary(path).isOk());

  OccupancyMapper mapper(o);
  for (int frame = 0; frame < 3; ++frame)
    mapper.insertFrame(Eigen::Vector3d::Zero(), randomPoints(rng, 150));
  const Status st = mapper.writeBinary(path);
  ASSERT_TRUE(st.isOk()) << st.message();
  EXPECT_FALSE(fs::exists(path + ".partial"));

  octomap::OcTree read_back(path);
  const std::vector<Voxel> expected = mapper.occupiedVoxels();
  const std::vector<Voxel> got = occupiedVoxels(read_back);
  ASSERT_GT(expected.size(), 100U);
  ASSERT_EQ(got.size(), expected.size());
  for (size_t i = 0; i < got.size(); ++i) {
    ASSERT_NEAR((got[i].centre_m - expected[i].centre_m).norm(), 0.0, kCentreTol) << i;
  }
  EXPECT_DOUBLE_EQ(read_back.getResolution(), o.resolution_m);
}

TEST(OccupancyMapper, WriteBinaryFailureLeavesAnExistingFileIntact) {
  const std::string dir = test::makeTempDir("mapping_write_binary_fail");
  const std::string path = dir + "/map.bt";
  const std::string old_content = "previous map";
  { std::ofstream(path) << old_content; }
  OccupancyMapper mapper(defaultOptions());
  mapper.insertFrame(Eigen::Vector3d::Zero(), {Eigen::Vector3d(1.01, 0.01, 0.01)});

  // The scratch file cannot be created (a folder is in its way; chmod would not stop root).
  fs::create_directory(path + ".partial");
  const Status st = mapper.writeBinary(path);
  ASSERT_FALSE(st.isOk());
  EXPECT_NE(st.message().find(".partial"), std::string::npos) << st.message();
  std::ifstream in(path);
  const std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(content, old_content);

  // A missing folder fails with its path in the message.
  const Status missing = mapper.writeBinary(dir + "/no_such_folder/map.bt");
  ASSERT_FALSE(missing.isOk());
  EXPECT_NE(missing.message().find("no_such_folder"), std::string::npos) << missing.message();

  // The rename fails when a non-empty folder holds the target name; the scratch file goes.
  const std::string blocked = dir + "/blocked.bt";
  fs::create_directories(blocked + "/inside");
  const Status rename_failed = mapper.writeBinary(blocked);
  ASSERT_FALSE(rename_failed.isOk());
  EXPECT_FALSE(fs::exists(blocked + ".partial"));
  EXPECT_TRUE(fs::is_directory(blocked + "/inside"));
}

}  // namespace
}  // namespace twocam::mapping
