#include "slam/module/line_cloud_localizer.h"

#include <random>

#include <gtest/gtest.h>

#include "slam/geometry/so3.h"

namespace lcv::slam {
namespace {

OrbDescriptor RandomDescriptor(std::mt19937_64& rng) {
  OrbDescriptor d;
  for (auto& byte : d) byte = static_cast<std::uint8_t>(rng() & 0xff);
  return d;
}

// Flips `bits` distinct random bits (a descriptor seen again under noise).
OrbDescriptor FlipBits(OrbDescriptor d, int bits, std::mt19937_64& rng) {
  std::vector<int> positions(256);
  for (int i = 0; i < 256; ++i) positions[i] = i;
  std::shuffle(positions.begin(), positions.end(), rng);
  for (int k = 0; k < bits; ++k) d[positions[k] / 8] ^= static_cast<std::uint8_t>(1u << (positions[k] % 8));
  return d;
}

CameraParams MakeCameraParams(CameraModel model) {
  CameraParams p;
  p.model = model;
  if (model == CameraModel::kEquirectangular) {
    p.cols = 1280;
    p.rows = 640;
  } else {
    p.cols = 640;
    p.rows = 480;
    p.fx = p.fy = 500;
    p.cx = 319.5;
    p.cy = 239.5;
  }
  return p;
}

// A line cloud of points around a camera (a room 10 m across) with random directions and
// descriptors, and a query frame: the visible points' keypoints (1 px noise, descriptors with 10
// flipped bits), 30% features with random descriptors, 10% features that match a wrong line.
struct Query {
  Map line_cloud;
  Rigid3d cam_from_world;
  std::vector<Keypoint> keypoints;
  std::vector<OrbDescriptor> descriptors;
  std::vector<Id> true_line;  // per keypoint, kInvalidId for outliers
};

Query MakeQuery(std::uint64_t seed, const Camera& camera, int num_points) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> pixel_noise(0.0, 1.0);
  Query q;
  q.cam_from_world = Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.3 * u(rng), Eigen::Vector3d(u(rng), u(rng), 1).normalized())),
                             Eigen::Vector3d(u(rng), u(rng), u(rng)));
  const Rigid3d world_from_cam = q.cam_from_world.Inverse();
  std::vector<Eigen::Vector3d> hidden;
  for (Id id = 1; id <= static_cast<Id>(num_points); ++id) {
    Eigen::Vector3d x_cam(u(rng), u(rng), u(rng));
    x_cam *= 5.0;
    if (camera.model() != CameraModel::kEquirectangular) x_cam.z() = 2.0 + 4.0 * std::abs(u(rng));
    LineLandmark line;
    line.id = id;
    const Eigen::Vector3d d = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    line.line = Line3d(world_from_cam * x_cam + 2.0 * u(rng) * d, d);
    line.descriptor = RandomDescriptor(rng);
    q.line_cloud.lines[id] = line;
    hidden.push_back(x_cam);
  }
  for (Id id = 1; id <= static_cast<Id>(num_points); ++id) {
    const auto px = camera.Project(hidden[id - 1]);
    if (!px || !camera.InImage(*px)) continue;
    const double r = std::uniform_real_distribution<double>(0, 1)(rng);
    Keypoint kp;
    kp.x = static_cast<float>(px->x() + pixel_noise(rng));
    kp.y = static_cast<float>(px->y() + pixel_noise(rng));
    if (r < 0.3) {
      q.descriptors.push_back(RandomDescriptor(rng));
      q.true_line.push_back(kInvalidId);
    } else if (r < 0.4) {
      const Id wrong = 1 + (id + 7) % num_points;
      q.descriptors.push_back(FlipBits(*q.line_cloud.lines.at(wrong).descriptor, 10, rng));
      q.true_line.push_back(kInvalidId);
    } else {
      q.descriptors.push_back(FlipBits(*q.line_cloud.lines.at(id).descriptor, 10, rng));
      q.true_line.push_back(id);
    }
    q.keypoints.push_back(kp);
  }
  return q;
}

TEST(LineCloudLocalizer, LocalizesPerspectiveAndEquirectangularQueries) {
  for (CameraModel model : {CameraModel::kPerspective, CameraModel::kEquirectangular}) {
    const std::unique_ptr<Camera> camera = MakeCamera(MakeCameraParams(model));
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
      const Query q = MakeQuery(seed, *camera, 300);
      LineCloudLocalizerOptions options;
      options.random_seed = seed;
      const LineCloudLocalizer localizer(q.line_cloud, *camera, options);
      EXPECT_EQ(localizer.num_matchable_lines(), 300);
      const LineCloudLocalization r = localizer.Localize(q.keypoints, q.descriptors);
      ASSERT_TRUE(r.success) << CameraModelName(model) << " seed " << seed << ": " << r.failure;
      EXPECT_LT((r.cam_from_world.Center() - q.cam_from_world.Center()).norm(), 0.05)
          << CameraModelName(model) << " seed " << seed;
      EXPECT_LT(AngularDistance(r.cam_from_world.rotation, q.cam_from_world.rotation), 0.005)
          << CameraModelName(model) << " seed " << seed;
      int correct = 0;
      for (const auto& [keypoint, line] : r.inliers) correct += q.true_line[keypoint] == line;
      EXPECT_GE(correct, static_cast<int>(r.inliers.size()) * 95 / 100);
      EXPECT_GE(r.num_matches, r.num_inliers);
    }
  }
}

TEST(LineCloudLocalizer, StopsWhenAskedAndSaysSo) {
  const std::unique_ptr<Camera> camera = MakeCamera(MakeCameraParams(CameraModel::kPerspective));
  const Query q = MakeQuery(2, *camera, 300);
  LineCloudLocalizerOptions options;
  options.random_seed = 2;
  const LineCloudLocalizer localizer(q.line_cloud, *camera, options);
  const LineCloudLocalization full = localizer.Localize(q.keypoints, q.descriptors);
  ASSERT_TRUE(full.success) << full.failure;
  EXPECT_FALSE(full.stopped_early);

  // Asked right after the matching: no RANSAC at all.
  const LineCloudLocalization none =
      localizer.Localize(q.keypoints, q.descriptors, 0, [] { return true; });
  EXPECT_FALSE(none.success);
  EXPECT_TRUE(none.stopped_early);
  EXPECT_EQ(none.num_trials, 0);
  EXPECT_EQ(none.num_matches, full.num_matches);
  EXPECT_NE(none.failure.find("stopped"), std::string::npos) << none.failure;

  // Asked after the matching and one sample: RANSAC stops after its first trial.
  int asked = 0;
  const LineCloudLocalization one =
      localizer.Localize(q.keypoints, q.descriptors, 0, [&asked] { return ++asked >= 2; });
  EXPECT_TRUE(one.stopped_early);
  EXPECT_EQ(one.num_trials, 1);
}

TEST(LineCloudLocalizer, ARotationPriorFindsThePoseWithoutP6L) {
  const std::unique_ptr<Camera> camera = MakeCamera(MakeCameraParams(CameraModel::kPerspective));
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    const Query q = MakeQuery(seed, *camera, 300);
    LineCloudLocalizerOptions options;
    options.random_seed = seed;
    options.min_rotation_prior_inliers = options.min_num_inliers;  // a small query
    const LineCloudLocalizer localizer(q.line_cloud, *camera, options);
    // The orientation as tracking had it (half a degree off): the centre search finds the pose,
    // the six-dof refinement removes the prior's error.
    const Eigen::Quaterniond prior =
        ExpSO3(Eigen::Vector3d(0.3, 1.0, -0.2).normalized() * 0.0087) * q.cam_from_world.rotation;
    const LineCloudLocalization r =
        localizer.Localize(q.keypoints, q.descriptors, 0, {}, 0, prior);
    ASSERT_TRUE(r.success) << "seed " << seed << ": " << r.failure;
    EXPECT_TRUE(r.from_rotation_prior) << "seed " << seed;
    EXPECT_GT(r.num_rotation_prior_trials, 0);
    EXPECT_EQ(r.num_trials, 0) << "p6L ran";
    EXPECT_LT((r.cam_from_world.Center() - q.cam_from_world.Center()).norm(), 0.05)
        << "seed " << seed;
    EXPECT_LT(AngularDistance(r.cam_from_world.rotation, q.cam_from_world.rotation), 0.005)
        << "seed " << seed;

    // A prior that is 90 degrees off finds nothing, and p6L takes over.
    const Eigen::Quaterniond wrong =
        ExpSO3(Eigen::Vector3d(0.0, 1.5707963, 0.0)) * q.cam_from_world.rotation;
    const LineCloudLocalization fallback =
        localizer.Localize(q.keypoints, q.descriptors, 0, {}, 0, wrong);
    ASSERT_TRUE(fallback.success) << "seed " << seed << ": " << fallback.failure;
    EXPECT_FALSE(fallback.from_rotation_prior) << "seed " << seed;
    EXPECT_GT(fallback.num_trials, 0);
    EXPECT_LT((fallback.cam_from_world.Center() - q.cam_from_world.Center()).norm(), 0.05);

    // A prior's pose with fewer inliers than min_rotation_prior_inliers is not kept: p6L runs.
    LineCloudLocalizerOptions demanding = options;
    demanding.min_rotation_prior_inliers = r.num_inliers + 1;
    const LineCloudLocalizer strict(q.line_cloud, *camera, demanding);
    const LineCloudLocalization searched =
        strict.Localize(q.keypoints, q.descriptors, 0, {}, 0, prior);
    EXPECT_FALSE(searched.from_rotation_prior) << "seed " << seed;
    EXPECT_GT(searched.num_rotation_prior_trials, 0);
    EXPECT_GT(searched.num_trials, 0) << "p6L did not run";
  }
}

TEST(LineCloudLocalizer, AmbiguousAndUndescribedLinesAreNotMatched) {
  const std::unique_ptr<Camera> camera = MakeCamera(MakeCameraParams(CameraModel::kPerspective));
  Query q = MakeQuery(5, *camera, 300);
  // Half the lines lose their descriptor (a map imported without them), a quarter get the
  // descriptor of another line (the ratio test must reject both).
  int described = 0;
  for (auto& [id, line] : q.line_cloud.lines) {
    if (id % 2 == 0) line.descriptor.reset();
  }
  for (auto& [id, line] : q.line_cloud.lines) {
    if (id % 4 == 1 && q.line_cloud.lines.count(id + 2)) {
      q.line_cloud.lines.at(id + 2).descriptor = line.descriptor;
    }
    described += line.descriptor.has_value();
  }
  const LineCloudLocalizer localizer(q.line_cloud, *camera, LineCloudLocalizerOptions());
  EXPECT_EQ(localizer.num_matchable_lines(), described);
  const LineCloudLocalization r = localizer.Localize(q.keypoints, q.descriptors);
  for (const auto& [keypoint, line] : r.inliers) {
    EXPECT_EQ(line % 2, 1u) << "a line without descriptor was matched";
    EXPECT_NE(line % 4, 1u) << "an ambiguous descriptor passed the ratio test";
    EXPECT_NE(line % 4, 3u) << "an ambiguous descriptor passed the ratio test";
  }
}

TEST(LineCloudLocalizer, TooFewMatchesFailWithAReason) {
  const std::unique_ptr<Camera> camera = MakeCamera(MakeCameraParams(CameraModel::kPerspective));
  const Query q = MakeQuery(9, *camera, 300);
  std::vector<Keypoint> few(q.keypoints.begin(), q.keypoints.begin() + 8);
  std::vector<OrbDescriptor> few_descriptors(q.descriptors.begin(), q.descriptors.begin() + 8);
  const LineCloudLocalizer localizer(q.line_cloud, *camera, LineCloudLocalizerOptions());
  const LineCloudLocalization r = localizer.Localize(few, few_descriptors);
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.failure.find("matches <"), std::string::npos) << r.failure;
  LineCloudLocalizerOptions bad;
  bad.min_num_inliers = 5;
  EXPECT_NE(bad.Problem().find("min_num_inliers"), std::string::npos);
}

}  // namespace
}  // namespace lcv::slam
