#include "privacy/concealed_check.h"

#include <cstdlib>
#include <string>

#include <gtest/gtest.h>

#include "privacy/concealed_regions.h"
#include "slam/util/error.h"
#include "tests/privacy/line_cloud_fixture.h"

namespace lcv::privacy {
namespace {

// A published map with one concealed object (a box around (0,0,5)) and a client map built
// around it by hand: a camera at the origin looking down +z.
class ConcealedCheckTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    region_.name = "laptop";
    region_.box = Eigen::AlignedBox3d(Eigen::Vector3d(-0.2, -0.2, 4.8), Eigen::Vector3d(0.2, 0.2, 5.2));
    slam::Map points;
    for (slam::Id id = 1; id <= 200; ++id) {
      // 50 points on the object, 150 elsewhere.
      const Eigen::Vector3d x = id <= 50 ? Eigen::Vector3d(0.4 * u(rng) - 0.2, 0.4 * u(rng) - 0.2, 5.0)
                                         : Eigen::Vector3d(6 * u(rng) - 3, 6 * u(rng) - 3, 8 + u(rng));
      points.points[id].id = id;
      points.points[id].position = x;
    }
    reference_ = points;
    published_ = testing::MakeLineCloud(points, 18);
    slam::CameraParams cam;
    cam.cols = 640;
    cam.rows = 480;
    cam.fx = cam.fy = 500;
    cam.cx = 319.5;
    cam.cy = 239.5;
    client_.cameras[1] = cam;
    slam::Keyframe kf;
    kf.id = 500;
    kf.camera_id = 1;
    client_.keyframes[500] = kf;
    // A client point far from the object.
    client_.points[600].id = 600;
    client_.points[600].position = Eigen::Vector3d(2.5, 2.5, 8.5);
    spec_.regions.push_back(region_);
  }
  // Adds a keypoint where x projects in a client keyframe (default: 500); returns its index.
  std::uint32_t AddKeypoint(const Eigen::Vector3d& x, slam::Id keyframe_id = 500) {
    slam::Keyframe& kf = client_.keyframes.at(keyframe_id);
    const Eigen::Vector3d p = kf.cam_from_world * x;
    slam::Keypoint kp;
    kp.x = static_cast<float>(500 * p.x() / p.z() + 319.5);
    kp.y = static_cast<float>(500 * p.y() / p.z() + 239.5);
    kf.keypoints.push_back(kp);
    return static_cast<std::uint32_t>(kf.keypoints.size() - 1);
  }
  // A client point X at x, seen by the keyframe at the origin and a second one (501) `baseline`
  // to its side (both looking down +z), with exact keypoints.
  slam::PointLandmark TwoViewPoint(const Eigen::Vector3d& x, double baseline) {
    slam::Keyframe side = client_.keyframes.at(500);
    side.id = 501;
    side.keypoints.clear();
    side.cam_from_world.translation = Eigen::Vector3d(-baseline, 0, 0);  // centre (baseline, 0, 0)
    client_.keyframes[501] = side;
    slam::PointLandmark p;
    p.id = 605;
    p.position = x;
    for (const slam::Id id : {slam::Id{500}, slam::Id{501}}) {
      p.observations.push_back({id, AddKeypoint(x, id)});
    }
    return p;
  }
  // Of the concealed lines that leave the box through its top face z = 5.2 (away from its
  // edges), the steepest: where it leaves, and |d_z|.
  double SteepestExitThroughTheTop(Eigen::Vector3d* exit_point) const {
    double steepest = 0.0;
    for (slam::Id id = 1; id <= 50; ++id) {
      const slam::Line3d& line = published_.lines.at(id).line;
      if (std::abs(line.direction.z()) <= steepest) continue;
      const Eigen::Vector3d e = line.PointAt((5.2 - line.anchor.z()) / line.direction.z());
      if (std::abs(e.x()) > 0.17 || std::abs(e.y()) > 0.17) continue;
      steepest = std::abs(line.direction.z());
      *exit_point = e;
    }
    return steepest;
  }
  ConcealedRegion region_;
  ConcealedSpec spec_;
  slam::Map reference_, published_, client_;
};

TEST_F(ConcealedCheckTest, CleanClientMapPasses) {
  const ConcealedCheckResult r = CheckConcealedLines(published_, client_, spec_, nullptr);
  EXPECT_TRUE(r.passed());
  EXPECT_GE(r.num_concealed_lines, 50);
  EXPECT_EQ(r.num_points_checked, 1);
}

// Planted leak: a client point X within epsilon of a concealed line inside the region.
TEST_F(ConcealedCheckTest, ClientPointNearConcealedLineIsReported) {
  const slam::LineLandmark& victim = published_.lines.at(7);
  const Eigen::Vector3d x = reference_.points.at(7).position + Eigen::Vector3d(0, 0.01, 0);
  client_.points[601].id = 601;
  client_.points[601].position = x;
  const ReferenceMatch match = MatchReference(published_, reference_);
  const ConcealedCheckResult r = CheckConcealedLines(published_, client_, spec_, &match);
  EXPECT_EQ(r.num_concealed_lines, 50) << "with the reference, only lines whose point is inside";
  ASSERT_FALSE(r.passed());
  bool found = false;
  for (const auto& v : r.violations) {
    EXPECT_EQ(v.kind, "point_near_concealed_line");
    EXPECT_EQ(v.point_id, 601u);
    EXPECT_EQ(v.region, "laptop");
    EXPECT_LE(v.distance_m, 0.05);
    found |= v.line_id == victim.id;
  }
  EXPECT_TRUE(found);
}

// Planted leak: X' restored on a concealed line. With a real observation it is a proximity
// violation; without one, also an observation violation.
TEST_F(ConcealedCheckTest, RestoredPointOnConcealedLine) {
  slam::LineLandmark l = published_.lines.at(3);
  l.restored_point = reference_.points.at(3).position;
  client_.lines[3] = l;
  ConcealedCheckResult r = CheckConcealedLines(published_, client_, spec_, nullptr);
  int near = 0, unsupported = 0;
  for (const auto& v : r.violations) {
    near += v.kind == "restored_point_near_concealed_line" && v.point_id == 3 && v.line_id == 3;
    unsupported += v.kind == "restored_point_without_observations" && v.point_id == 3;
  }
  EXPECT_EQ(near, 1);
  EXPECT_EQ(unsupported, 1);

  client_.lines[3].observations.push_back({500, AddKeypoint(*l.restored_point)});
  r = CheckConcealedLines(published_, client_, spec_, nullptr);
  unsupported = 0;
  for (const auto& v : r.violations) unsupported += v.kind == "restored_point_without_observations";
  EXPECT_EQ(unsupported, 0);
  EXPECT_FALSE(r.passed());
}

// X' away from concealed lines but fabricated: its observation does not see it.
TEST_F(ConcealedCheckTest, FabricatedRestoredPointIsReported) {
  slam::LineLandmark l = published_.lines.at(120);
  l.restored_point = reference_.points.at(120).position;
  l.observations.push_back({500, AddKeypoint(*l.restored_point + Eigen::Vector3d(0.5, 0, 0))});
  client_.lines[120] = l;
  const ConcealedCheckResult r = CheckConcealedLines(published_, client_, spec_, nullptr);
  ASSERT_EQ(r.violations.size(), 1u);
  EXPECT_EQ(r.violations[0].kind, "restored_point_without_observations");
  EXPECT_NE(r.violations[0].reason.find("px"), std::string::npos) << r.violations[0].reason;
}

// A client point just outside the object's box (the desk under a removed document) near a
// concealed line's part inside the box is not the object's: only points in the box (up to the
// margin) count; a negative margin restores the box grown by epsilon.
TEST_F(ConcealedCheckTest, PointOutsideTheRegionIsNotTheObjects) {
  const ReferenceMatch match = MatchReference(published_, reference_);
  // The concealed line that leaves the box through its top face z = 5.2 most steeply; the
  // planted point sits 2 cm above where it leaves: outside the box, within epsilon of the part.
  Eigen::Vector3d exit_point = Eigen::Vector3d::Zero();
  ASSERT_GT(SteepestExitThroughTheTop(&exit_point), 0.9) << "set-up: a steep concealed line";
  client_.points[603].id = 603;
  client_.points[603].position = exit_point + Eigen::Vector3d(0, 0, 0.02);
  ConcealedCheckResult r = CheckConcealedLines(published_, client_, spec_, &match);
  EXPECT_TRUE(r.passed()) << "2 cm outside the box, beyond the 1 cm margin";
  ConcealedCheckOptions no_margin;
  no_margin.point_region_margin_m = -1.0;
  r = CheckConcealedLines(published_, client_, spec_, &match, no_margin);
  ASSERT_FALSE(r.passed()) << "within epsilon of a concealed line's part in the box";
  EXPECT_EQ(r.violations[0].point_id, 603u);
  EXPECT_LE(r.violations[0].distance_m, 0.0201);
}

// The object rested on something the client sees (here: its top face z = 5.2 under a shelf):
// a client point just inside that face, near a concealed line's part, is the shelf's surface
// seen where the object used to be, so the region shrinks by the margin across the face. The
// same point in a region without a resting face is a violation.
TEST_F(ConcealedCheckTest, PointOnTheSurfaceTheObjectRestedOnIsNotTheObjects) {
  const ReferenceMatch match = MatchReference(published_, reference_);
  Eigen::Vector3d exit_point = Eigen::Vector3d::Zero();
  ASSERT_GT(SteepestExitThroughTheTop(&exit_point), 0.9) << "set-up: a steep concealed line";
  client_.points[604].id = 604;
  client_.points[604].position = exit_point - Eigen::Vector3d(0, 0, 0.005);  // 5 mm inside
  ConcealedCheckResult r = CheckConcealedLines(published_, client_, spec_, &match);
  ASSERT_FALSE(r.passed()) << "inside the box, on a concealed line's part";
  EXPECT_EQ(r.violations[0].point_id, 604u);
  ConcealedSpec resting = spec_;
  resting.regions[0].rests_max[2] = true;
  r = CheckConcealedLines(published_, client_, resting, &match);
  EXPECT_TRUE(r.passed()) << "within the margin of the face it rested on";
  // Deeper inside than the margin it is the object's again.
  client_.points[604].position = exit_point - Eigen::Vector3d(0, 0, 0.03);
  r = CheckConcealedLines(published_, client_, resting, &match);
  EXPECT_FALSE(r.passed()) << "3 cm inside, 3 cm from the line at most";
}

// A point whose two views barely differ (5 cm apart, 5 m away: 0.6 degrees of parallax) may lie
// anywhere within about a metre along its ray as far as its observations go, so its position
// inside the object says nothing: it is cleared (the desk point of `lcv demo` seen through a
// removed document). The same point seen over a 3 m baseline is pinned within centimetres: a
// violation. Judged by position alone (--points-by-position), the first is one too.
TEST_F(ConcealedCheckTest, PointsAreJudgedByWhereTheirObservationsPlaceThem) {
  const ReferenceMatch match = MatchReference(published_, reference_);
  const Eigen::Vector3d hidden = reference_.points.at(7).position;
  client_.points[605] = TwoViewPoint(hidden, 0.05);
  ConcealedCheckResult r = CheckConcealedLines(published_, client_, spec_, &match);
  EXPECT_TRUE(r.passed()) << r.violations.size() << " violations";
  EXPECT_EQ(r.num_points_cleared_by_observations, 1);

  ConcealedCheckOptions by_position;
  by_position.clear_points_by_observations = false;
  r = CheckConcealedLines(published_, client_, spec_, &match, by_position);
  ASSERT_FALSE(r.passed());
  EXPECT_EQ(r.violations[0].point_id, 605u);
  EXPECT_EQ(r.num_points_cleared_by_observations, 0);

  client_.keyframes.at(500).keypoints.clear();
  client_.points[605] = TwoViewPoint(hidden, 3.0);
  r = CheckConcealedLines(published_, client_, spec_, &match);
  ASSERT_FALSE(r.passed()) << "well triangulated: its observations keep it on the line";
  EXPECT_EQ(r.violations[0].point_id, 605u);
  EXPECT_EQ(r.num_points_cleared_by_observations, 0);
}

// A point whose observations do not see it where it is (planted, or corrupt) is judged by its
// position.
TEST_F(ConcealedCheckTest, PointItsObservationsRejectIsJudgedByPosition) {
  const Eigen::Vector3d hidden = reference_.points.at(7).position;
  client_.points[605] = TwoViewPoint(hidden + Eigen::Vector3d(0.3, 0, 0), 0.05);
  client_.points[605].position = hidden;
  const ReferenceMatch match = MatchReference(published_, reference_);
  const ConcealedCheckResult r = CheckConcealedLines(published_, client_, spec_, &match);
  ASSERT_FALSE(r.passed());
  EXPECT_EQ(r.violations[0].point_id, 605u);
  EXPECT_EQ(r.num_points_cleared_by_observations, 0);
}

TEST_F(ConcealedCheckTest, ListedLineIds) {
  ConcealedSpec by_id;
  by_id.line_ids = {150};
  client_.points[602].id = 602;
  client_.points[602].position = published_.lines.at(150).line.PointAt(3.0);
  const ConcealedCheckResult r = CheckConcealedLines(published_, client_, by_id, nullptr);
  ASSERT_EQ(r.violations.size(), 1u);
  EXPECT_EQ(r.violations[0].line_id, 150u);
}

TEST(ConcealedRegions, ParsesRegionsAndScene) {
  const ConcealedSpec a = ParseConcealedRegions(
      R"({"regions": [{"name": "laptop", "min": [0, 0, 0], "max": [1, 2, 3]}], "line_ids": [4, 5]})",
      "r.json");
  ASSERT_EQ(a.regions.size(), 1u);
  EXPECT_EQ(a.regions[0].name, "laptop");
  EXPECT_EQ(a.regions[0].box.max(), Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(a.line_ids, (std::vector<slam::Id>{4, 5}));
  const ConcealedSpec s = ParseSceneConcealedRegions(
      R"({"objects": [{"name": "mug", "bbox_min": [0,0,0], "bbox_max": [1,1,1], "in_map": true, "in_client": false},
                      {"name": "desk", "bbox_min": [0,0,0], "bbox_max": [2,1,1], "in_map": true, "in_client": true},
                      {"name": "wall", "bbox_min": [0,0,0], "bbox_max": [2,1,1]}]})",
      "scene.json");
  ASSERT_EQ(s.regions.size(), 1u);
  EXPECT_EQ(s.regions[0].name, "mug");
  // Its bottom face z = 0 lies on the desk's bottom face (a box around it); nothing else touches.
  EXPECT_TRUE(s.regions[0].rests_min[2]);
}

// lcv synth's desk: a document standing on the desk (its bottom face on the desk's top), inside
// a room; a lamp floating above the desk touches nothing; an object on the room's floor rests on
// the room's inside.
TEST(ConcealedRegions, MarksTheFacesThatRestOnVisibleObjects) {
  const ConcealedSpec s = ParseSceneConcealedRegions(
      R"({"objects": [
        {"name": "room", "bbox_min": [-3,-3,0], "bbox_max": [3,3,3], "in_map": true, "in_client": true},
        {"name": "desk", "bbox_min": [-1,0,0], "bbox_max": [1,1,0.75], "in_map": true, "in_client": true},
        {"name": "document", "bbox_min": [0,0.4,0.75], "bbox_max": [0.3,0.43,0.97], "in_map": true, "in_client": false},
        {"name": "lamp", "bbox_min": [0,0.4,1.2], "bbox_max": [0.2,0.6,1.5], "in_map": true, "in_client": false},
        {"name": "bin", "bbox_min": [2,2,0], "bbox_max": [2.3,2.3,0.4], "in_map": true, "in_client": false}]})",
      "scene.json");
  ASSERT_EQ(s.regions.size(), 3u);
  const Eigen::Array<bool, 3, 1> none = Eigen::Array<bool, 3, 1>::Constant(false);
  const Eigen::Array<bool, 3, 1> bottom(false, false, true);
  EXPECT_TRUE((s.regions[0].rests_min == bottom).all()) << "document on the desk";
  EXPECT_TRUE((s.regions[0].rests_max == none).all());
  EXPECT_TRUE((s.regions[1].rests_min == none).all()) << "the lamp floats";
  EXPECT_TRUE((s.regions[1].rests_max == none).all());
  EXPECT_TRUE((s.regions[2].rests_min == bottom).all()) << "the bin on the room's floor";
  // A concealed object does not support another concealed object: only what the client sees.
}

TEST(ConcealedRegions, BadFilesNameFileAndField) {
  auto message = [](auto&& f) {
    try {
      f();
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message([] { ParseConcealedRegions("{", "r.json"); }).rfind("r.json: not valid JSON", 0), 0u);
  EXPECT_EQ(message([] {
              ParseConcealedRegions(R"({"regions": [{"min": [0, 0], "max": [1, 1, 1]}]})", "r.json");
            }),
            "r.json: /regions/0/min: expected an array of 3 numbers");
  EXPECT_EQ(message([] {
              ParseConcealedRegions(R"({"regions": [{"min": [2, 0, 0], "max": [1, 1, 1]}]})", "r.json");
            }),
            "r.json: /regions/0: \"max\" is below \"min\" on some axis");
  EXPECT_EQ(message([] { ParseConcealedRegions(R"({"line_ids": [-1]})", "r.json"); }),
            "r.json: /line_ids/0: expected a non-negative integer id");
  EXPECT_EQ(message([] {
              ParseSceneConcealedRegions(R"({"objects": [{"name": "x", "in_client": false}]})",
                                         "scene.json");
            }),
            "scene.json: /objects/0: a concealed object needs \"bbox_min\" and \"bbox_max\"");
  EXPECT_EQ(message([] {
              ParseSceneConcealedRegions(R"({"objects": [{"name": "x", "in_map": "no"}]})",
                                         "scene.json");
            }),
            "scene.json: /objects/0/in_map: expected true or false");
  EXPECT_EQ(message([] { ReadConcealedRegions("/nonexistent/regions.json"); })
                .rfind("/nonexistent/regions.json", 0),
            0u);
}

}  // namespace
}  // namespace lcv::privacy

namespace lcv::privacy {
namespace {

// The reader understands what `lcv synth --scenario desk` actually writes: the object removed
// from the client sequence is the one concealed region.
TEST(ConcealedRegions, ReadsTheDeskScenarioOfLcvSynth) {
  const std::string dir = ::testing::TempDir() + "/lcv_concealed_desk";
  const std::string command = std::string(LCV_BINARY) + " synth --scenario desk --frames 2 --size 80x45 --out " + dir + " 2>/dev/null >/dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  const ConcealedSpec spec = ReadSceneConcealedRegions(dir + "/scene.json");
  ASSERT_EQ(spec.regions.size(), 1u);
  EXPECT_GT(spec.regions[0].box.volume(), 0.0);
  EXPECT_FALSE(spec.regions[0].name.empty());
}

}  // namespace
}  // namespace lcv::privacy
