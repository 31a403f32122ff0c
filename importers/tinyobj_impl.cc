// The one translation unit that compiles tinyobjloader's implementation
// (Debian's libtinyobjloader-dev is header-only for us; we never link
// libtinyobjloader.so). Only importers/obj_import.cc uses it.
#define TINYOBJLOADER_IMPLEMENTATION
#include <tiny_obj_loader.h>
