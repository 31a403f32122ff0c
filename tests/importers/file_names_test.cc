// importers/import.h: the parts of a file's path (FileExtension, FileBaseName,
// FileFolder, FileStem), as the importers, the SDK and the CLI name files.
#include <string>

#include <gtest/gtest.h>

#include "importers/import.h"

namespace meshstream {
namespace {

TEST(FileNames, ExtensionIsLowerCaseWithItsDotAndOnlyInTheFileName) {
  EXPECT_EQ(FileExtension("models/Bunny.OBJ"), ".obj");
  EXPECT_EQ(FileExtension("scene.v2.gltf"), ".gltf");
  EXPECT_EQ(FileExtension("dir.d/README"), "");
  EXPECT_EQ(FileExtension("noext"), "");
  EXPECT_EQ(FileExtension(".obj"), ".obj");
}

TEST(FileNames, BaseNameIsWhatFollowsTheLastSlash) {
  EXPECT_EQ(FileBaseName("models/horse.ply"), "horse.ply");
  EXPECT_EQ(FileBaseName("/a/b/c.glb"), "c.glb");
  EXPECT_EQ(FileBaseName("horse.ply"), "horse.ply");
  EXPECT_EQ(FileBaseName("dir/"), "");
  EXPECT_EQ(FileBaseName(""), "");
}

TEST(FileNames, FolderKeepsItsSlashAndCompletesTheBaseName) {
  EXPECT_EQ(FileFolder("models/horse.ply"), "models/");
  EXPECT_EQ(FileFolder("/scene.gltf"), "/");
  EXPECT_EQ(FileFolder("horse.ply"), "");
  for (const std::string path : {"a/b/c.gltf", "/x", "x", "dir/", ""}) {
    EXPECT_EQ(FileFolder(path) + FileBaseName(path), path) << path;
  }
}

TEST(FileNames, StemDropsTheLastExtensionOfTheFileName) {
  EXPECT_EQ(FileStem("models/horse.ply"), "horse");
  EXPECT_EQ(FileStem("scene.v2.gltf"), "scene.v2");
  EXPECT_EQ(FileStem("dir.d/README"), "README");
  EXPECT_EQ(FileStem("noext"), "noext");
  EXPECT_EQ(FileStem("dir/.obj"), ".obj");  // a leading dot is part of the name
  EXPECT_EQ(FileStem("dir/"), "");
}

}  // namespace
}  // namespace meshstream
