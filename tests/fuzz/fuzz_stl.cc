// libFuzzer target for the STL, ascii and binary (our check, then OpenMesh) importer
// (docs/design/design.md, "Hostile input" gets a clear error, never a crash).
// Each input is written to a temporary .stl file and read through ImportFile;
// see mesh_file_fuzz.h for what is checked. Built as a real libFuzzer binary
// with MESHSTREAM_FUZZ=ON (make fuzz), and always as fuzz_stl_replay,
// which replays corpus/stl/ under ctest.
#include <cstddef>
#include <cstdint>

#include "tests/fuzz/mesh_file_fuzz.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return meshstream_fuzz::RunMeshFile("fuzz_stl", ".stl", data, size);
}
