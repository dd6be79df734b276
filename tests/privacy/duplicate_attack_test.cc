#include "privacy/duplicate_attack.h"

#include <gtest/gtest.h>

#include "tests/privacy/line_cloud_fixture.h"

namespace lcv::privacy {
namespace {

// Plants a second line through the hidden point of line `of`, with a new random direction.
void PlantDuplicate(slam::Map* lines, slam::Id of, slam::Id new_id, const Eigen::Vector3d& x,
                    bool keep_descriptor) {
  slam::LineLandmark copy = lines->lines.at(of);
  const Eigen::Vector3d d = Eigen::Vector3d(0.3, -0.8, 0.52).normalized();
  copy.id = new_id;
  copy.line = slam::Line3d(x - d.dot(x) * d, d);
  if (!keep_descriptor) copy.descriptor.reset();
  lines->lines[new_id] = copy;
}

TEST(DuplicateAttack, CleanLineCloudHasNoPairs) {
  const slam::Map points = testing::MakeStreetPointMap(3000, 1);
  const slam::Map lines = testing::MakeLineCloud(points, 1);
  std::vector<DuplicatePair> pairs;
  const LineAttackResult r = RunDuplicateAttack(lines, {}, &pairs);
  EXPECT_TRUE(pairs.empty());
  for (double risk : r.risk) EXPECT_EQ(risk, 0.0);
}

TEST(DuplicateAttack, FindsPlantedPairByDescriptor) {
  const slam::Map points = testing::MakeStreetPointMap(3000, 2);
  slam::Map lines = testing::MakeLineCloud(points, 2);
  const auto& [victim_id, victim] = *std::next(points.points.begin(), 1234);
  PlantDuplicate(&lines, victim_id, 900000, victim.position, true);
  std::vector<DuplicatePair> pairs;
  const LineAttackResult r = RunDuplicateAttack(lines, {}, &pairs);
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0].line_a, victim_id);
  EXPECT_EQ(pairs[0].line_b, 900000u);
  EXPECT_EQ(pairs[0].hamming, 0);
  EXPECT_LT((pairs[0].point - victim.position).norm(), 1e-6);
  EXPECT_EQ(r.risk[r.size() - 1], 1.0);
}

TEST(DuplicateAttack, FindsPlantedPairByVisibilityWithoutDescriptors) {
  const slam::Map points = testing::MakeStreetPointMap(3000, 3);
  slam::Map lines = testing::MakeLineCloud(points, 3);
  for (auto& [id, l] : lines.lines) l.descriptor.reset();  // as imported from COLMAP
  const auto& [victim_id, victim] = *std::next(points.points.begin(), 77);
  PlantDuplicate(&lines, victim_id, 900001, victim.position, false);
  std::vector<DuplicatePair> pairs;
  RunDuplicateAttack(lines, {}, &pairs);
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0].hamming, -1);
  EXPECT_GE(pairs[0].shared_keyframes, 2);
}

TEST(DuplicateAttack, IntersectingLinesWithoutEvidenceAreNotDuplicates) {
  const slam::Map points = testing::MakeStreetPointMap(3000, 4);
  slam::Map lines = testing::MakeLineCloud(points, 4);
  const auto& [victim_id, victim] = *std::next(points.points.begin(), 10);
  PlantDuplicate(&lines, victim_id, 900002, victim.position, false);
  // A descriptor far from the victim's: the lines meet, but nothing says they are one point.
  ASSERT_TRUE(lines.lines.at(victim_id).descriptor.has_value());
  slam::OrbDescriptor other = *lines.lines.at(victim_id).descriptor;
  for (auto& b : other) b = static_cast<std::uint8_t>(~b);
  lines.lines.at(900002).descriptor = other;
  std::vector<DuplicatePair> pairs;
  RunDuplicateAttack(lines, {}, &pairs);
  EXPECT_TRUE(pairs.empty());
}

}  // namespace
}  // namespace lcv::privacy
