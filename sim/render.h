// Headless rendering: one world of a SimModel drawn by MuJoCo's own renderer (mjv_/mjr_) into an
// offscreen OpenGL context, no display or GPU needed, and 8-bit RGB PNG files.
// The GL backend (OSMesa or EGL) is chosen when CMake configures (BIDEX_RENDER_GL, see
// sim/README.md); OpenGL, OSMesa, EGL and libpng stay out of this header.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "sim/hand_spec.h"
#include "sim/model.h"

struct mjData_;
typedef struct mjData_ mjData;

namespace bidex::sim {

// A free camera orbiting `lookat` (MuJoCo's mjvCamera): it looks along azimuth (degrees about +z,
// from +x towards +y) and elevation (degrees, negative looks down) from `distance` metres away.
struct Camera {
  Vec3 lookat{0, 0, 0};
  double distance = 1.5;
  double azimuth_deg = 90;
  double elevation_deg = -30;
};

struct RenderOptions {
  int width = 640;   // pixels, 1 to 4096
  int height = 480;  // pixels, 1 to 4096
  Camera camera;
};

// 8-bit RGB pixels, rows top to bottom, width * height * 3 bytes.
struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;
};

// The offscreen GL backend this build renders with: "osmesa", "egl" or "none".
const char* render_backend();

// A camera that frames the whole scene for an image of the given aspect (width / height): it
// looks at the centre of the world-aligned bounding box of every geom except planes and height
// fields (at `data`'s qpos, or the model's initial pose when `data` is null), across the box's
// longer horizontal side turned 30 degrees, from 30 degrees above, at the nearest distance that
// keeps the whole box in view with a 10% margin.
Camera framing_camera(const SimModel& model, const mjData* data, double aspect = 4.0 / 3.0);

// Renders one world. `data` is read (copied) only: its qpos (and mocap poses) set the picture,
// the positions are recomputed from them, so it need not have been forwarded. Geoms, sites and
// lights as MuJoCo's viewer shows them by default. Creates and destroys its own GL context, so
// it may be called from any thread; calls are serialised inside. Throws bidex::Error when no GL
// context can be made (no backend in this build, or the backend fails) or the size is invalid.
// Must not run while another thread steps the same mjData.
Image render(const SimModel& model, const mjData* data, const RenderOptions& options);

// Writes an 8-bit RGB PNG atomically (temp file + rename; parent folders are created, as
// write_file_atomic does). Throws IoError naming the path, bidex::Error for a malformed image.
void write_png(const Image& image, const std::string& path);

// Reads a PNG as 8-bit RGB (other formats are converted: alpha dropped, 16 bits cut to 8).
// Throws IoError naming the path when it cannot be read or is not a PNG.
Image read_png(const std::string& path);

}  // namespace bidex::sim
