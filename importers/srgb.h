// sRGB-encoded colour channels to linear (mesh.h: COLOR_0 is linear RGBA);
// OBJ, PLY and OFF colours are taken as sRGB.
//
// Contract: pure; c is expected in [0, 1], other values are mapped by the
// same formula (NaN stays NaN, which ValidateScene refuses).
// Safe on untrusted input: any float. Thread safety: none needed.
#ifndef MESHSTREAM_IMPORTERS_SRGB_H_
#define MESHSTREAM_IMPORTERS_SRGB_H_

#include <cmath>

namespace meshstream {
namespace mesh_io {

// sRGB-encoded channel in [0, 1] to linear.
inline float SrgbToLinear(float c) {
  if (c <= 0.04045f) return c / 12.92f;
  return static_cast<float>(std::pow((static_cast<double>(c) + 0.055) / 1.055, 2.4));
}

}  // namespace mesh_io
}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_SRGB_H_
