#include "codec/progressive/view_order.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>

namespace meshstream {

namespace {

// Row r of a column-major matrix applied to (x, y, z, 1).
double Row(const std::array<double, 16>& m, int r, const Vec3d& p) {
  return m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r];
}

double RowScale(const std::array<double, 16>& m, int r) {
  return std::sqrt(m[r] * m[r] + m[4 + r] * m[4 + r] + m[8 + r] * m[8 + r]);
}

std::array<Vec3d, 8> Corners(const Box& b) {
  std::array<Vec3d, 8> out;
  for (int i = 0; i < 8; ++i) {
    out[i] = {(i & 1) ? b.hi[0] : b.lo[0], (i & 2) ? b.hi[1] : b.lo[1], (i & 4) ? b.hi[2] : b.lo[2]};
  }
  return out;
}

}  // namespace

Status CheckView(const View& view) {
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(view.camera[a])) return InvalidInput("view.camera_position[" + std::to_string(a) + "] is not finite");
  }
  for (int i = 0; i < 16; ++i) {
    if (!std::isfinite(view.view_projection[i])) {
      return InvalidInput("view.view_projection[" + std::to_string(i) + "] is not finite");
    }
  }
  if (view.viewport_width == 0 || view.viewport_width > kMaxViewportPixels) {
    return InvalidInput("view.viewport_width " + std::to_string(view.viewport_width) + " is outside [1, " +
                        std::to_string(kMaxViewportPixels) + "]");
  }
  if (view.viewport_height == 0 || view.viewport_height > kMaxViewportPixels) {
    return InvalidInput("view.viewport_height " + std::to_string(view.viewport_height) + " is outside [1, " +
                        std::to_string(kMaxViewportPixels) + "]");
  }
  if (RowScale(view.view_projection, 0) == 0 && RowScale(view.view_projection, 1) == 0) {
    return InvalidInput("view.view_projection shows nothing (rows 0 and 1 have no x, y or z)");
  }
  return Status::Ok();
}

Box TransformBox(const Box& box, const std::array<double, 16>& m) {
  Box out;
  out.lo = {INFINITY, INFINITY, INFINITY};
  out.hi = {-INFINITY, -INFINITY, -INFINITY};
  for (const Vec3d& c : Corners(box)) {
    for (int r = 0; r < 3; ++r) {
      const double v = Row(m, r, c);
      out.lo[r] = std::min(out.lo[r], v);
      out.hi[r] = std::max(out.hi[r], v);
    }
  }
  return out;
}

bool OutsideFrustum(const View& view, const Box& box) {
  const std::array<Vec3d, 8> corners = Corners(box);
  std::array<std::array<double, 4>, 8> clip;
  for (int i = 0; i < 8; ++i) {
    for (int r = 0; r < 4; ++r) clip[i][r] = Row(view.view_projection, r, corners[i]);
  }
  // The six planes: -w <= x, x <= w, and the same for y and z.
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = -1; side <= 1; side += 2) {
      bool all_out = true;
      for (int i = 0; i < 8 && all_out; ++i) all_out = side * clip[i][axis] > clip[i][3];
      if (all_out) return true;
    }
  }
  return false;
}

double ScreenError(const View& view, const Box& box, double error) {
  if (!(error > 0)) return 0;
  Vec3d nearest;
  for (int a = 0; a < 3; ++a) nearest[a] = std::clamp(view.camera[a], box.lo[a], box.hi[a]);
  const std::array<double, 16>& m = view.view_projection;
  // At the camera (inside the box) or behind it, the nearest depth there is:
  // a hundred-thousandth of the box's size (the error fills the screen).
  double diagonal = 0;
  for (int a = 0; a < 3; ++a) diagonal += (box.hi[a] - box.lo[a]) * (box.hi[a] - box.lo[a]);
  const double w = std::max(Row(m, 3, nearest), std::max(std::sqrt(diagonal), 1e-30) * 1e-5);
  const double scale = std::max(RowScale(m, 0) * view.viewport_width, RowScale(m, 1) * view.viewport_height) / 2;
  const double pixels = error * scale / w;
  return std::isfinite(pixels) ? pixels : 0;
}

View LookAtView(const Vec3d& eye, const Vec3d& target, double fov_y_degrees, uint32_t width, uint32_t height,
                double near_plane, double far_plane) {
  auto unit = [](const Vec3d& v) {
    const double n = Norm(v);
    return n > 0 ? Vec3d{v[0] / n, v[1] / n, v[2] / n} : v;
  };
  const Vec3d f = unit(Sub(target, eye));
  Vec3d up = {0, 1, 0};
  if (std::abs(Dot(f, up)) > 0.999) up = {0, 0, 1};
  const Vec3d s = unit(Cross(f, up));
  const Vec3d u = Cross(s, f);
  // The view matrix (rows s, u, -f), then the perspective.
  const double aspect = height > 0 ? static_cast<double>(width) / height : 1.0;
  const double t = 1.0 / std::tan(fov_y_degrees * 3.14159265358979323846 / 360.0);
  const double a = (far_plane + near_plane) / (near_plane - far_plane);
  const double b = 2 * far_plane * near_plane / (near_plane - far_plane);
  const std::array<Vec3d, 3> rows = {s, u, Vec3d{-f[0], -f[1], -f[2]}};
  const std::array<double, 3> translation = {-Dot(s, eye), -Dot(u, eye), Dot(f, eye)};
  View v;
  v.camera = eye;
  v.viewport_width = width;
  v.viewport_height = height;
  std::array<double, 16>& m = v.view_projection;
  m.fill(0);
  for (int c = 0; c < 3; ++c) {
    m[4 * c + 0] = t / aspect * rows[0][c];
    m[4 * c + 1] = t * rows[1][c];
    m[4 * c + 2] = a * rows[2][c];
    m[4 * c + 3] = -rows[2][c];
  }
  m[12] = t / aspect * translation[0];
  m[13] = t * translation[1];
  m[14] = a * translation[2] + b;
  m[15] = -translation[2];
  return v;
}

StatusOr<View> LookAtViewFromText(const std::string& text) {
  std::vector<double> v;
  for (size_t at = 0; at <= text.size();) {
    const size_t comma = std::min(text.find(',', at), text.size());
    const std::string item = text.substr(at, comma - at);
    char* end = nullptr;
    const double d = std::strtod(item.c_str(), &end);
    if (item.empty() || end != item.c_str() + item.size() || !std::isfinite(d)) {
      return InvalidArgument("view: '" + item + "' is not a number (EX,EY,EZ,TX,TY,TZ[,FOV,W,H])");
    }
    v.push_back(d);
    at = comma + 1;
  }
  if (v.size() != 6 && v.size() != 9) {
    return InvalidArgument("view: 6 or 9 numbers (EX,EY,EZ,TX,TY,TZ[,FOV,W,H]), not " + std::to_string(v.size()));
  }
  const double fov = v.size() == 9 ? v[6] : 60;
  if (!(fov > 0 && fov < 180)) return InvalidArgument("view: the field of view is in (0, 180) degrees");
  const double w = v.size() == 9 ? v[7] : 1280, h = v.size() == 9 ? v[8] : 720;
  if (!(w >= 1 && w <= kMaxViewportPixels && h >= 1 && h <= kMaxViewportPixels) || w != std::floor(w) ||
      h != std::floor(h)) {
    return InvalidArgument("view: the viewport is whole pixels in [1, " + std::to_string(kMaxViewportPixels) + "]");
  }
  const double distance = Norm(Sub({v[3], v[4], v[5]}, {v[0], v[1], v[2]}));
  if (!(distance > 0)) return InvalidArgument("view: the eye and the target are the same point");
  const View view = LookAtView({v[0], v[1], v[2]}, {v[3], v[4], v[5]}, fov, static_cast<uint32_t>(w),
                               static_cast<uint32_t>(h), distance / 1000, distance * 1000);
  const Status checked = CheckView(view);
  if (!checked.ok()) return InvalidArgument(checked.message());
  return view;
}

std::vector<std::vector<double>> ViewErrors(const View& view, const std::vector<Box>& bounds,
                                            const std::vector<std::vector<double>>& errors) {
  std::vector<std::vector<double>> out(errors.size());
  for (size_t p = 0; p < errors.size(); ++p) {
    if (p >= bounds.size()) {
      out[p] = errors[p];
      continue;
    }
    const bool outside = OutsideFrustum(view, bounds[p]);
    out[p].reserve(errors[p].size());
    for (double e : errors[p]) out[p].push_back(outside ? e * kOutsideWeight : ScreenError(view, bounds[p], e));
  }
  return out;
}

}  // namespace meshstream
