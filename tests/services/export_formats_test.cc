// The export formats' table (proto/export_formats.h): one row per enumerator
// and per value of the API's Format enum, names and values unique, and the
// lookups the CLI, gRPC and HTTP make through it.
#include "proto/export_formats.h"

#include <set>
#include <string>

#include <gtest/gtest.h>

namespace meshstream {
namespace {

TEST(ExportFormats, OneRowPerFormatAndPerApiValue) {
  std::set<std::string> names;
  std::set<int> protos, formats;
  for (const ExportFormatInfo& info : ExportFormats()) {
    EXPECT_TRUE(names.insert(info.name).second) << info.name;
    EXPECT_TRUE(protos.insert(info.proto).second) << info.name;
    EXPECT_TRUE(formats.insert(static_cast<int>(info.format)).second) << info.name;
    EXPECT_EQ(&InfoOf(info.format), &info);
    EXPECT_EQ(ExportFormatNamed(info.name), &info);
    EXPECT_EQ(ExportFormatOf(info.proto), &info);
  }
  // Every value of the API's enum but FORMAT_UNSPECIFIED has a row.
  const google::protobuf::EnumDescriptor* e = v1::Format_descriptor();
  for (int i = 0; i < e->value_count(); ++i) {
    const int value = e->value(i)->number();
    if (value == v1::FORMAT_UNSPECIFIED) {
      EXPECT_EQ(ExportFormatOf(v1::FORMAT_UNSPECIFIED), nullptr);
    } else {
      EXPECT_TRUE(protos.count(value)) << e->value(i)->name() << " has no row";
    }
  }
  EXPECT_EQ(ExportFormats().size(), static_cast<size_t>(e->value_count() - 1));
}

TEST(ExportFormats, NamesAndLookups) {
  EXPECT_EQ(ExportFormatNames(), "glb, draco, progressive, obj, ply");
  EXPECT_EQ(ExportFormatProtoNames(), "FORMAT_GLB, FORMAT_DRACO_GLB, FORMAT_PROGRESSIVE_GLB, FORMAT_OBJ, FORMAT_PLY");
  EXPECT_EQ(ExportFormatNamed("GLB"), nullptr);  // names are case-sensitive, as the route and the CLI were
  EXPECT_EQ(ExportFormatNamed(""), nullptr);
  EXPECT_EQ(ExportFormatOf(static_cast<v1::Format>(99)), nullptr);
  EXPECT_FALSE(InfoOf(ExportFormat::kProgressiveGlb).decodes);  // served as stored
  EXPECT_TRUE(InfoOf(ExportFormat::kDracoGlb).decodes);
  EXPECT_STREQ(InfoOf(ExportFormat::kPly).extension, ".ply");
}

TEST(ExportFormats, FormatForExtension) {
  EXPECT_EQ(ExportFormatForExtension(".obj").format, ExportFormat::kObj);
  EXPECT_EQ(ExportFormatForExtension(".ply").format, ExportFormat::kPly);
  EXPECT_EQ(ExportFormatForExtension(".glb").format, ExportFormat::kGlb);
  EXPECT_EQ(ExportFormatForExtension(".gltf").format, ExportFormat::kGlb);
  EXPECT_EQ(ExportFormatForExtension("").format, ExportFormat::kGlb);
}

}  // namespace
}  // namespace meshstream
