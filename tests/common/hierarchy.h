// A progressive hierarchy of a test mesh without Draco: the base is kept as
// it is (a placeholder byte stands for its bytes), for the tests of one
// coding tool that need the encoder's real refinements but no container.
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
