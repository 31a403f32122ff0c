// The one translation unit that compiles tinygltf. Its namespace is renamed
// to meshstream_tinygltf by a PUBLIC definition of the importers target, so
// it cannot collide with the copy of tinygltf inside libdraco.so (docs/architecture.md,
// "The tinygltf/Draco trap"). Images are never decoded (no stb_image; the TINYGLTF_NO_*
// definitions are PUBLIC on the target so every user sees one class layout);
// external images are
// read by gltf_import.cc itself, inside the asset's folder only.
#define TINYGLTF_IMPLEMENTATION
#include <tiny_gltf.h>
