// importers/draco_codec.h: KHR_draco_mesh_compression's "attributes" object
// both ways (DracoAttributeNames, AddDracoAttribute), as the session's start
// carries it from the server's plan to the SDK.
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "importers/draco_codec.h"

namespace meshstream {
namespace {

TEST(DracoAttributes, NamesAndIdsRoundTrip) {
  DracoAttributeIds ids;
  ids.position = 0;
  ids.normal = 1;
  ids.texcoords = {2, 4};
  ids.color = 3;
  const std::map<std::string, int> names = DracoAttributeNames(ids);
  EXPECT_EQ(names, (std::map<std::string, int>{
                       {"POSITION", 0}, {"NORMAL", 1}, {"TEXCOORD_0", 2}, {"TEXCOORD_1", 4}, {"COLOR_0", 3}}));
  DracoAttributeIds back;
  for (const auto& [name, id] : names) ASSERT_TRUE(AddDracoAttribute(name, id, back).ok()) << name;
  EXPECT_EQ(back.position, 0);
  EXPECT_EQ(back.normal, 1);
  EXPECT_EQ(back.texcoords, (std::vector<int>{2, 4}));
  EXPECT_EQ(back.color, 3);
}

TEST(DracoAttributes, AbsentAttributesAreNotNamed) {
  DracoAttributeIds ids;
  ids.position = 5;
  EXPECT_EQ(DracoAttributeNames(ids), (std::map<std::string, int>{{"POSITION", 5}}));
}

TEST(DracoAttributes, UnknownSemanticsAreIgnoredAndTexcoordGapsStayAbsent) {
  DracoAttributeIds ids;
  EXPECT_TRUE(AddDracoAttribute("TANGENT", 7, ids).ok());
  EXPECT_TRUE(AddDracoAttribute("_CUSTOM", 8, ids).ok());
  EXPECT_TRUE(AddDracoAttribute("TEXCOORD_2", 9, ids).ok());
  EXPECT_EQ(ids.position, -1);
  EXPECT_EQ(ids.texcoords, (std::vector<int>{-1, -1, 9}));
}

TEST(DracoAttributes, ATexcoordWithoutAOneOrTwoDigitIndexIsRefusedNamingIt) {
  for (const char* name : {"TEXCOORD_", "TEXCOORD_x", "TEXCOORD_100", "TEXCOORD_-1"}) {
    DracoAttributeIds ids;
    const Status s = AddDracoAttribute(name, 1, ids);
    EXPECT_EQ(s.code(), StatusCode::kInvalidInput) << name;
    EXPECT_EQ(s.message(), std::string("Draco attribute ") + name);
  }
}

}  // namespace
}  // namespace meshstream
