// The MessagePack view behind the map reader (mapping/io/msgpack_value.h): types as
// nlohmann-json reads them, sizes, skipping nested values, member lookup, and the map reader
// agreeing with nlohmann's DOM on MessagePack-only spellings (signed integers, ext, repeated keys).
#include "mapping/io/msgpack_value.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "mapping/io/map_file.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

using internal::MsgpackFormatError;
using internal::MsgpackValue;
using nlohmann::json;

std::string Bytes(std::initializer_list<int> values) {
  std::string out;
  for (const int v : values) out += static_cast<char>(v);
  return out;
}

MsgpackValue View(const std::string& bytes) {
  return MsgpackValue(reinterpret_cast<const unsigned char*>(bytes.data()));
}

TEST(MsgpackValue, TypesAndNumbersAsNlohmannReadsThem) {
  const std::vector<std::string> values = {
      Bytes({0x05}),                    // positive fixint
      Bytes({0xff}),                    // negative fixint -1
      Bytes({0xcc, 0xc8}),              // uint 8: 200
      Bytes({0xcd, 0x12, 0x34}),        // uint 16
      Bytes({0xd0, 0x05}),              // int 8: 5 (signed spelling of a positive number)
      Bytes({0xd1, 0xff, 0x38}),        // int 16: -200
      Bytes({0xca, 0x3f, 0xc0, 0, 0}),  // float 32: 1.5
      Bytes({0xcb, 0x40, 0x09, 0x21, 0xfb, 0x54, 0x44, 0x2d, 0x18}),  // float 64: pi
      Bytes({0xc0}), Bytes({0xc3}), Bytes({0xa2, 'h', 'i'}), Bytes({0xc4, 2, 7, 8}),
      Bytes({0xd4, 1, 9}),  // fixext 1: binary in nlohmann
  };
  for (const std::string& bytes : values) {
    const json reference = json::from_msgpack(bytes);
    const MsgpackValue v = View(bytes);
    SCOPED_TRACE(reference.dump());
    EXPECT_EQ(v.is_null(), reference.is_null());
    EXPECT_EQ(v.is_string(), reference.is_string());
    EXPECT_EQ(v.is_binary(), reference.is_binary());
    EXPECT_EQ(v.is_number(), reference.is_number());
    EXPECT_EQ(v.is_number_unsigned(), reference.is_number_unsigned());
    EXPECT_EQ(v.is_number_integer(), reference.is_number_integer());
    if (reference.is_number()) {
      EXPECT_EQ(v.as_double(), reference.get<double>());
      if (reference.is_number_integer()) {
        EXPECT_EQ(v.as_integer(), reference.get<std::int64_t>());
      }
    }
    if (reference.is_string()) {
      EXPECT_EQ(v.bytes(), reference.get<std::string>());
    }
    if (reference.is_binary()) {
      EXPECT_EQ(v.bytes().size(), reference.get_binary().size());
    } else {
      EXPECT_EQ(v.Describe(100), reference.dump());
    }
    EXPECT_EQ(v.Next().Raw(), static_cast<const void*>(bytes.data() + bytes.size()));
  }
}

TEST(MsgpackValue, WalksNestedValuesAndFindsMembers) {
  const json document = {{"a", {1, 2, {{"deep", {3.5, "x", json::binary({1, 2, 3})}}}}},
                         {"b", json::array()},
                         {"c", "text"}};
  const std::vector<std::uint8_t> packed = json::to_msgpack(document);
  const std::string bytes(packed.begin(), packed.end());
  const MsgpackValue root = View(bytes);
  ASSERT_TRUE(root.is_object());
  EXPECT_EQ(root.size(), 3u);
  EXPECT_EQ(root.Next().Raw(), static_cast<const void*>(bytes.data() + bytes.size()));
  const MsgpackValue::Members members = root.MembersOf();
  const MsgpackValue a = members.Find("a");
  ASSERT_TRUE(a.valid() && a.is_array());
  EXPECT_EQ(a.size(), 3u);
  std::vector<double> numbers;
  a.ForEachElement([&](const MsgpackValue& e) {
    if (e.is_number()) numbers.push_back(e.as_double());
  });
  EXPECT_EQ(numbers, (std::vector<double>{1, 2}));
  EXPECT_TRUE(members.Find("b").is_array());
  EXPECT_EQ(members.Find("b").size(), 0u);
  EXPECT_EQ(members.Find("c").bytes(), "text");
  EXPECT_FALSE(members.Find("missing").valid());

  // A repeated key: the last one counts, as in nlohmann's DOM.
  const std::string repeated = Bytes({0x82, 0xa1, 'k', 0x01, 0xa1, 'k', 0x02});
  EXPECT_EQ(View(repeated).MembersOf().Find("k").as_unsigned(), 2u);
  EXPECT_EQ(json::from_msgpack(repeated)["k"], 2);
  // A key that is not a string is a format error (nlohmann refuses the file).
  EXPECT_THROW(View(Bytes({0x81, 0x01, 0x02})).MembersOf(), MsgpackFormatError);
  EXPECT_THROW(json::from_msgpack(Bytes({0x81, 0x01, 0x02})), json::exception);
}

// The reader's answer for a MessagePack document equals its answer for the same document as
// JSON text (nlohmann's DOM), accepted or rejected.
std::string Outcome(const std::string& bytes) {
  try {
    const slam::Map map = ParseMap(bytes, "m");
    return "accepted: " + std::to_string(map.keyframes.size()) + " keyframes, " +
           std::to_string(map.points.size()) + " points";
  } catch (const InputError& e) {
    return e.what();
  }
}

TEST(MsgpackValue, MapReaderAgreesWithTheJsonDecoder) {
  const json camera = {{"id", 0}, {"model", "perspective"}, {"cols", 640}, {"rows", 480},
                       {"fx", 500}, {"fy", 500}, {"cx", 319.5}, {"cy", 239.5}};
  const json keyframe = {
      {"id", 1}, {"camera_id", 0}, {"timestamp", 0.5},
      {"cam_from_world", {{"rotation_wxyz", {1, 0, 0, 0}}, {"translation", {0, 0, 0}}}},
      {"keypoints", {{10.5, 20.25, 30, 0}, {1, 2, -1, 1}}},
      {"descriptors", {std::string(64, 'a'), std::string(64, 'b')}}};
  const json point = {{"id", 2}, {"position", {1, 2, 3}},
                      {"covariance", {1, 0, 0, 0, 1, 0, 0, 0, 1}},
                      {"observations", {{1, 0}}}};
  const json good = {{"magic", "lcvmap"}, {"schema_version", 1}, {"cameras", {camera}},
                     {"keyframes", {keyframe}}, {"points", {point}}};
  std::vector<json> documents = {good};
  json bad = good;
  bad["points"][0]["id"] = -2;
  documents.push_back(bad);
  bad = good;
  bad["keyframes"][0]["keypoints"][1][3] = 1.5;
  documents.push_back(bad);
  bad = good;
  bad["points"][0]["observations"][0] = {1, 0, 0};
  documents.push_back(bad);
  bad = good;
  bad["keyframes"][0]["timestamp"] = "soon";
  documents.push_back(bad);
  bad = good;
  bad["schema_version"] = 2;
  documents.push_back(bad);
  for (const json& document : documents) {
    const std::vector<std::uint8_t> packed = json::to_msgpack(document);
    const std::string from_pack = Outcome(std::string(packed.begin(), packed.end()));
    EXPECT_EQ(from_pack, Outcome(document.dump()));
  }
  const std::vector<std::uint8_t> packed = json::to_msgpack(good);
  std::string bytes(packed.begin(), packed.end());
  EXPECT_EQ(Outcome(bytes), "accepted: 1 keyframes, 1 points");
  // A signed spelling of an id: nlohmann reads int 8 as a signed integer, so both decoders
  // refuse it as an id.
  const std::string id_key = Bytes({0xa2, 'i', 'd', 0x02});  // "id": 2 of the point
  const std::size_t at = bytes.rfind(id_key);
  ASSERT_NE(at, std::string::npos);
  bytes.replace(at, id_key.size(), Bytes({0xa2, 'i', 'd', 0xd0, 0x02}));
  EXPECT_NE(Outcome(bytes).find("/points/0/id: expected a non-negative integer"),
            std::string::npos)
      << Outcome(bytes);
}

}  // namespace
}  // namespace lcv::mapping
