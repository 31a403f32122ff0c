// Names of uploaded files: a resource is a relative path inside the upload
// and nothing else; the main file is a plain name whose extension chooses
// the importer.
#include "proto/api_names.h"

#include <string>

#include <gtest/gtest.h>

namespace meshstream {
namespace {

std::string Refusal(const std::string& name) {
  const Status s = CheckResourceName(name);
  EXPECT_FALSE(s.ok()) << "accepted: " << name;
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument) << name;
  return s.message();
}

TEST(PipelineResource, TraversalAndAmbiguousNamesAreRefused) {
  EXPECT_EQ(Refusal("../a.bin"), "resource name '../a.bin': '..' segments are not allowed");
  EXPECT_EQ(Refusal("/etc/passwd"), "resource name '/etc/passwd': an absolute path");
  EXPECT_EQ(Refusal("a/../../b"), "resource name 'a/../../b': '..' segments are not allowed");
  EXPECT_EQ(Refusal("a\\b"), "resource name 'a\\b': holds a backslash (use '/')");
  EXPECT_EQ(Refusal("C:x"), "resource name 'C:x': starts with a drive letter");
  EXPECT_EQ(Refusal("c:/x"), "resource name 'c:/x': starts with a drive letter");
  EXPECT_EQ(Refusal(""), "resource name '': empty");
  EXPECT_EQ(Refusal("."), "resource name '.': '.' segments are not allowed");
  EXPECT_EQ(Refusal("./a"), "resource name './a': '.' segments are not allowed");
  EXPECT_EQ(Refusal("a/."), "resource name 'a/.': '.' segments are not allowed");
  EXPECT_EQ(Refusal(".."), "resource name '..': '..' segments are not allowed");
  EXPECT_EQ(Refusal("a/.."), "resource name 'a/..': '..' segments are not allowed");
  EXPECT_EQ(Refusal("a//b"), "resource name 'a//b': empty segments ('//' or a trailing '/') are not allowed");
  EXPECT_EQ(Refusal("a/"), "resource name 'a/': empty segments ('//' or a trailing '/') are not allowed");
  EXPECT_EQ(Refusal(std::string("a\0b", 3)), "resource name 'a?b': holds a NUL byte");
  EXPECT_EQ(Refusal("a\nb"), "resource name 'a?b': holds a control character");
  EXPECT_EQ(Refusal("\xff\xfe.png"), "resource name '\xEF\xBF\xBD\xEF\xBF\xBD.png': not valid UTF-8");
  EXPECT_EQ(Refusal("\xc0\xaf.png").find("not valid UTF-8") != std::string::npos, true);  // overlong '/'
  const std::string long_name(kMaxResourceNameBytes + 1, 'a');
  const std::string m = Refusal(long_name);
  EXPECT_NE(m.find("513 bytes exceed 512"), std::string::npos) << m;
  EXPECT_LT(m.size(), 200u);  // the name is shortened in the message
}

TEST(PipelineResource, RelativePathsInsideTheUploadAreAccepted) {
  for (const std::string name : {"textures/wood.png", "scene.bin", "a/b/c/d.jpg", "..a", "a..", "a.b/c..d", ".hidden",
                                 "with space.png", "текстуры/дерево.png", "C", "1:x", "a/C:x"}) {
    EXPECT_TRUE(CheckResourceName(name).ok()) << name << ": " << CheckResourceName(name).ToString();
  }
  EXPECT_TRUE(CheckResourceName(std::string(kMaxResourceNameBytes, 'a')).ok());
}

TEST(PipelineResource, MainFilenameIsAPlainNameWithASupportedExtension) {
  for (const std::string name : {"bunny.obj", "Scene.GLTF", "model.glb", "horse.PLY", "x.off", "part.Stl"}) {
    EXPECT_TRUE(CheckMainFilename(name).ok()) << name << ": " << CheckMainFilename(name).ToString();
  }
  auto refusal = [](const std::string& name) {
    const Status s = CheckMainFilename(name);
    EXPECT_FALSE(s.ok()) << "accepted: " << name;
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
    EXPECT_EQ(s.message().rfind("filename '", 0), 0u) << s.message();
    return s.message();
  };
  EXPECT_NE(refusal("model.fbx").find("the extension must be .gltf .glb .obj .ply .off or .stl"), std::string::npos);
  EXPECT_NE(refusal("model").find("the extension must be"), std::string::npos);
  EXPECT_NE(refusal("dir/model.obj").find("may not hold '/'"), std::string::npos);
  EXPECT_NE(refusal("../model.obj").find("may not hold '/'"), std::string::npos);
  EXPECT_NE(refusal("/model.obj").find("absolute"), std::string::npos);
  EXPECT_NE(refusal("a\\model.obj").find("backslash"), std::string::npos);
  EXPECT_NE(refusal("").find("empty"), std::string::npos);
  EXPECT_NE(refusal("..").find("not a file name"), std::string::npos);
  EXPECT_NE(refusal(std::string("a\0.obj", 6)).find("NUL"), std::string::npos);
  EXPECT_NE(refusal("C:model.obj").find("drive letter"), std::string::npos);
  EXPECT_NE(refusal(std::string(300, 'a') + ".obj").find("exceed 255"), std::string::npos);
}

}  // namespace
}  // namespace meshstream
