// The encoder's real hierarchy of a test mesh, without Draco: the base
// coder hands the quantized base back as its own decode and one byte as its
// coded size. For the tests of one coding tool, which read the refinements
// and the base mesh and never the base's bytes.
#ifndef MESHSTREAM_TESTS_COMMON_HIERARCHY_H_
#define MESHSTREAM_TESTS_COMMON_HIERARCHY_H_

#include <gtest/gtest.h>

#include "codec/progressive/encoder.h"

namespace meshstream::test_util {

inline ProgressiveEncoded EncodeWithoutDraco(const Primitive& mesh, const ProgressiveEncodeOptions& options = {}) {
  auto enc = EncodeProgressive(mesh, options, [](const QuantizedMesh& base, int) -> StatusOr<EncodedBase> {
    EncodedBase e;
    e.decoded = base;
    e.bytes = {0};
    return e;
  });
  EXPECT_TRUE(enc.ok()) << enc.status().ToString();
  return enc.ok() ? std::move(enc).value() : ProgressiveEncoded{};
}

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTS_COMMON_HIERARCHY_H_
