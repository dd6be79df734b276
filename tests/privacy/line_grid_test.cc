#include "privacy/line_grid.h"

#include <random>
#include <set>

#include <gtest/gtest.h>

namespace lcv::privacy {
namespace {

TEST(LineGrid, ClipLineToBox) {
  const Eigen::AlignedBox3d box(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(2, 1, 1));
  double s0, s1;
  ASSERT_TRUE(ClipLineToBox(slam::Line3d({-1, 0.5, 0.5}, {1, 0, 0}), box, &s0, &s1));
  EXPECT_NEAR(s0, 1.0, 1e-12);
  EXPECT_NEAR(s1, 3.0, 1e-12);
  EXPECT_FALSE(ClipLineToBox(slam::Line3d({0, 5, 0}, {1, 0, 0}), box, &s0, &s1));
}

// Every voxel the walk reports is crossed by the line, and every voxel containing a point of the
// line (dense sampling) is reported, in order along the line.
TEST(LineGrid, TraverseMatchesDenseSampling) {
  const std::uint64_t seed = 3;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Eigen::AlignedBox3d box(Eigen::Vector3d(-1, -2, 0), Eigen::Vector3d(3, 2, 5));
  std::vector<slam::Line3d> lines;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d p(-1 + 4 * u(rng), -2 + 4 * u(rng), 5 * u(rng));
    lines.emplace_back(p, slam::UniformUnitVector(u(rng), u(rng)));
  }
  const LineGrid grid(lines, box, 0.37, 2);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    double s0, s1;
    ASSERT_TRUE(ClipLineToBox(lines[i], box, &s0, &s1));
    std::vector<std::size_t> walked;
    double last_exit = s0;
    grid.Traverse(lines[i], s0, s1, [&](std::size_t v, double a, double b) {
      EXPECT_NEAR(a, last_exit, 1e-9);
      EXPECT_LE(a, b + 1e-12);
      last_exit = b;
      walked.push_back(v);
      // The midpoint of the reported sub-segment lies in that voxel.
      const Eigen::Vector3i q = grid.VoxelOf(lines[i].PointAt(0.5 * (a + b)));
      EXPECT_EQ(grid.Index(q.x(), q.y(), q.z()), v);
      // And the line is listed in the voxel.
      EXPECT_TRUE(std::binary_search(grid.LinesBegin(v), grid.LinesEnd(v), i));
    });
    EXPECT_NEAR(last_exit, s1, 1e-9);
    const std::set<std::size_t> walked_set(walked.begin(), walked.end());
    EXPECT_EQ(walked_set.size(), walked.size()) << "a voxel visited twice";
    for (int k = 1; k < 1000; ++k) {
      const Eigen::Vector3i q = grid.VoxelOf(lines[i].PointAt(s0 + (s1 - s0) * k / 1000.0));
      EXPECT_TRUE(walked_set.count(grid.Index(q.x(), q.y(), q.z()))) << "line " << i;
    }
  }
}

TEST(LineGrid, CountsOnlyModeAgreesAndVoxelSizeHitsOccupancy) {
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Eigen::AlignedBox3d box(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(10, 10, 10));
  std::vector<slam::Line3d> lines;
  for (int i = 0; i < 5000; ++i) {
    lines.emplace_back(Eigen::Vector3d(10 * u(rng), 10 * u(rng), 10 * u(rng)),
                       slam::UniformUnitVector(u(rng), u(rng)));
  }
  const double voxel = ChooseVoxelSize(box, lines.size(), 20.0);
  const LineGrid full(lines, box, voxel, 2);
  const LineGrid counts(lines, box, voxel, 1, false);
  ASSERT_EQ(full.num_voxels(), counts.num_voxels());
  for (std::size_t v = 0; v < full.num_voxels(); ++v) ASSERT_EQ(full.Count(v), counts.Count(v));
  const double occupancy = static_cast<double>(full.num_entries()) / full.num_voxels();
  EXPECT_GT(occupancy, 10.0);
  EXPECT_LT(occupancy, 40.0);
}

}  // namespace
}  // namespace lcv::privacy
