// Refinement by view: what a viewer sees decides which refinements of a
// scene's primitives (and a large mesh's spatial parts) come first
// (docs/spec/streaming-protocol.md, "Views"; docs/design/codec.md, "Refinement
// by view").
//
// A refinement's importance for a view is the residual error before it
// (progressive/residual_error.h, in scene units) as the view sees it: the
// pixels that length spans at the point of its primitive's box nearest the
// camera, pixels = error x s / w, where w is that point's clip-space w (its
// depth in front of a perspective camera; 1 for an orthographic one) and s
// the larger of |row 0| x width / 2 and |row 1| x height / 2 over the first
// three columns of the view-projection matrix's rows (a perspective matrix's
// focal scales; a length across the view at depth w spans s / w pixels).
// A box wholly outside one plane of the view's frustum is not seen: its
// errors count kOutsideWeight of their scene size, which puts them after
// every seen refinement of the same error and keeps their own order.
// The scene's order and levels are then ScheduleSceneLevels's
// (scene_levels.h) over these errors: they are a positive multiple of the
// primitive's own errors, so its refinements keep their order.
//
// Contract: pure, safe on any input (CheckView says what a peer may send);
// O(primitives + refinements).
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_VIEW_ORDER_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_VIEW_ORDER_H_

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "codec/core/vec.h"

namespace meshstream {

struct View {
  Vec3d camera = {0, 0, 0};  // the eye, in scene (world) units
  // Column-major, as glTF and OpenGL: clip = M x (x, y, z, 1), visible where
  // -w <= x, y, z <= w.
  std::array<double, 16> view_projection = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  uint32_t viewport_width = 0;   // pixels
  uint32_t viewport_height = 0;
};

// The largest viewport side a view may have.
constexpr uint32_t kMaxViewportPixels = 65536;
// How much an error of a primitive outside the frustum counts.
constexpr double kOutsideWeight = 1e-9;

// InvalidInput naming the field: a non-finite number, a viewport side of 0
// or above kMaxViewportPixels, or a matrix whose first three columns of rows
// 0 and 1 are all zero (it shows nothing).
Status CheckView(const View& view);

struct Box {
  Vec3d lo = {0, 0, 0}, hi = {0, 0, 0};
};

// The axis-aligned box that holds `box` transformed by a column-major 4x4
// (affine) matrix.
Box TransformBox(const Box& box, const std::array<double, 16>& matrix);

// True when every corner of `box` lies outside one same plane of the frustum.
bool OutsideFrustum(const View& view, const Box& box);

// Pixels `error` spans at the point of `box` nearest the camera (above).
double ScreenError(const View& view, const Box& box, double error);

// A perspective camera at `eye` looking at `target` (+y up, or +z when the
// view is along y), vertical field of view `fov_y_degrees`, depth range
// [near, far]: what a client without its own matrices sends (fetch --view).
View LookAtView(const Vec3d& eye, const Vec3d& target, double fov_y_degrees, uint32_t width, uint32_t height,
                double near_plane, double far_plane);

// "EX,EY,EZ,TX,TY,TZ[,FOV,W,H]": LookAtView of that eye and target, FOV
// degrees (default 60, in (0, 180)), a W x H viewport (default 1280 x 720,
// whole pixels), depth range 1/1000 to 1000 x their distance; the form
// `meshstream fetch --view` and the benchmarks take. InvalidArgument naming
// what is wrong.
StatusOr<View> LookAtViewFromText(const std::string& text);

// Per primitive, its errors as `view` sees them (ScreenError, or
// kOutsideWeight x error outside the frustum). `bounds` and `errors` have
// one entry per primitive; an empty error vector stays empty.
std::vector<std::vector<double>> ViewErrors(const View& view, const std::vector<Box>& bounds,
                                            const std::vector<std::vector<double>>& errors);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_VIEW_ORDER_H_
