// sim/render: the reference scene rendered offscreen, the framing camera, PNG files written and
// read back, and the errors for bad sizes and bad paths.
#include "sim/render.h"

#include <cstdint>
#include <string>

#include <catch2/catch.hpp>
#include <mujoco/mujoco.h>

#include "core/error.h"
#include "core/files.h"
#include "sim/batch.h"
#include "tests/fixture.h"

using namespace bidex;
using namespace bidex::sim;
using bidex::test::TempDir;
using bidex::test::two_hand_model;

namespace {

// Share of pixels whose colour differs from the top-left corner's by more than `tol` (any channel).
double share_unlike_corner(const Image& img, int tol = 40) {
  const uint8_t* c = img.rgb.data();
  size_t n = static_cast<size_t>(img.width) * img.height, differ = 0;
  for (size_t i = 0; i < n; ++i) {
    const uint8_t* p = img.rgb.data() + 3 * i;
    for (int k = 0; k < 3; ++k)
      if (std::abs(int(p[k]) - int(c[k])) > tol) {
        ++differ;
        break;
      }
  }
  return static_cast<double>(differ) / static_cast<double>(n);
}

// Shares of warm pixels (red above blue by more than 30: the right hand, rgb .85 .72 .6, and the
// egg) and of cool ones (blue above red by more than 30: the left hand, .6 .72 .85); the floor
// (.25 .28 .32) and the shadows are neither.
std::pair<double, double> warm_cool(const Image& img) {
  size_t n = static_cast<size_t>(img.width) * img.height, warm = 0, cool = 0;
  for (size_t i = 0; i < n; ++i) {
    int r = img.rgb[3 * i], b = img.rgb[3 * i + 2];
    warm += r > b + 30;
    cool += b > r + 30;
  }
  return {static_cast<double>(warm) / n, static_cast<double>(cool) / n};
}

// Renders the reference scene in its initial pose, 160 x 120, framed; once per process.
const Image& reference_image() {
  static const Image img = [] {
    const SimModel& m = two_hand_model();
    RenderOptions o;
    o.width = 160;
    o.height = 120;
    o.camera = framing_camera(m, nullptr);
    return render(m, nullptr, o);
  }();
  return img;
}

// A synthetic 160 x 120 picture that uses every byte value in every channel.
Image gradient() {
  Image img{160, 120, std::vector<uint8_t>(160 * 120 * 3)};
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      uint8_t* p = img.rgb.data() + 3 * (y * img.width + x);
      p[0] = static_cast<uint8_t>(x + y);
      p[1] = static_cast<uint8_t>(x * y);
      p[2] = static_cast<uint8_t>(255 - x - 2 * y);
    }
  return img;
}

uint32_t big_endian(const std::string& s, size_t at) {
  uint32_t v = 0;
  for (size_t i = 0; i < 4; ++i) v = (v << 8) | static_cast<uint8_t>(s[at + i]);
  return v;
}

}  // namespace

TEST_CASE("framing_camera looks at the middle of the two hands from outside them",
          "[sim][render]") {
  const SimModel& m = two_hand_model();
  Camera c = framing_camera(m, nullptr);
  INFO("lookat " << c.lookat[0] << " " << c.lookat[1] << " " << c.lookat[2] << ", distance "
                 << c.distance << ", azimuth " << c.azimuth_deg);
  // the hands sit at y = 0 and y = -1.15, both around z = 0.5
  CHECK(c.lookat[1] < -0.3);
  CHECK(c.lookat[1] > -0.85);
  CHECK(c.lookat[2] > 0.2);
  CHECK(c.lookat[2] < 0.8);
  CHECK(c.distance > 1.0);
  CHECK(c.distance < 5.0);
  // the hands lie along y: the view runs mostly along x, not along the line of the hands
  double az = c.azimuth_deg * M_PI / 180.0;
  CHECK(std::abs(std::cos(az)) > std::abs(std::sin(az)));
  CHECK(c.elevation_deg < 0);

  // an mjData that was never forwarded gives the same camera: positions come from qpos
  mjData* d = mj_makeData(m.mj());
  Camera c2 = framing_camera(m, d);
  mj_deleteData(d);
  CHECK(c2.lookat == c.lookat);
  CHECK(c2.distance == c.distance);
}

TEST_CASE("render draws the two-hand scene offscreen", "[sim][render]") {
  INFO("backend: " << render_backend());
  const Image& img = reference_image();
  REQUIRE(img.width == 160);
  REQUIRE(img.height == 120);
  REQUIRE(img.rgb.size() == 160u * 120u * 3u);
  // hands, egg and shadows on the floor: not one colour (about 5% of the pixels differ from the
  // corner's floor colour by more than 40 at this framing), nor noise
  double share = share_unlike_corner(img);
  INFO("pixels unlike the corner: " << share);
  CHECK(share > 0.02);
  CHECK(share < 0.5);
  // both hands in the picture (about 1% warm and 2% cool pixels at this framing)
  auto [warm, cool] = warm_cool(img);
  INFO("warm pixels " << warm << ", cool pixels " << cool);
  CHECK(warm > 0.004);
  CHECK(cool > 0.008);
  // lit and shadowed: something bright, something dark
  int lo = 255, hi = 0;
  for (uint8_t v : img.rgb) {
    lo = std::min(lo, int(v));
    hi = std::max(hi, int(v));
  }
  CHECK(hi - lo > 100);
}

TEST_CASE("render draws a slot's qpos and leaves the slot untouched", "[sim][render]") {
  const SimModel& m = two_hand_model();
  SimBatch batch(m, 1);
  const mjData* d = batch.data(0);
  std::vector<double> qpos(d->qpos, d->qpos + m.nq());
  std::vector<double> xpos(d->xpos, d->xpos + 3 * m.nbody());
  RenderOptions o;
  o.width = 64;
  o.height = 48;
  o.camera = framing_camera(m, d, 64.0 / 48.0);
  Image a = render(m, d, o);
  CHECK(a.width == 64);
  CHECK(a.height == 48);
  CHECK(std::equal(qpos.begin(), qpos.end(), d->qpos));
  CHECK(std::equal(xpos.begin(), xpos.end(), d->xpos));
  // a fresh slot is at the initial pose: the same picture as no data at all, pixel for pixel
  CHECK(render(m, nullptr, o).rgb == a.rgb);

  // the left hand lifted 20 cm in qpos alone (positions not recomputed): the picture changes
  mjData* moved = mj_copyData(nullptr, m.mj(), d);
  moved->qpos[m.hand(Side::kLeft)->base_qpos_adr + 2] += 0.2;
  Image b = render(m, moved, o);
  mj_deleteData(moved);
  CHECK(b.rgb != a.rgb);
}

TEST_CASE("render rejects bad sizes and cameras with an Error", "[sim][render]") {
  const SimModel& m = two_hand_model();
  RenderOptions o;
  o.width = 0;
  CHECK_THROWS_WITH(render(m, nullptr, o), Catch::Contains("0x480") && Catch::Contains("size"));
  o.width = 5000;
  CHECK_THROWS_AS(render(m, nullptr, o), Error);
  o.width = 32;
  o.camera.distance = 0;
  CHECK_THROWS_WITH(render(m, nullptr, o), Catch::Contains("distance"));
}

TEST_CASE("write_png writes a PNG that reads back to the same pixels", "[sim][render]") {
  const Image img = gradient();
  TempDir dir;
  std::string path = dir.file("scene.png");
  write_png(img, path);
  CHECK(dir.list() == std::vector<std::string>{"scene.png"});  // no temp file left

  // the file itself: PNG signature, then IHDR with the size, 8-bit RGB (colour type 2)
  std::string bytes = read_file(path);
  REQUIRE(bytes.size() > 33);
  CHECK(bytes.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0);
  CHECK(bytes.compare(12, 4, "IHDR") == 0);
  CHECK(big_endian(bytes, 16) == 160);
  CHECK(big_endian(bytes, 20) == 120);
  CHECK(bytes[24] == 8);
  CHECK(bytes[25] == 2);

  Image back = read_png(path);
  CHECK(back.width == img.width);
  CHECK(back.height == img.height);
  CHECK(back.rgb == img.rgb);

  // rows run top to bottom: a one-pixel-wide image with a red top row and a blue bottom row
  Image two{1, 2, {255, 0, 0, 0, 0, 255}};
  write_png(two, dir.file("two.png"));
  CHECK(read_png(dir.file("two.png")).rgb == two.rgb);
}

TEST_CASE("write_png and read_png report bad paths and bad images", "[sim][render]") {
  const Image img = gradient();
  TempDir dir;
  // a parent "folder" that is a regular file cannot be created
  write_file_atomic(dir.file("plain"), "not a folder");
  std::string bad = dir.file("plain") + "/sub/scene.png";
  CHECK_THROWS_AS(write_png(img, bad), IoError);
  CHECK_THROWS_WITH(write_png(img, bad), Catch::Contains(bad));

  std::string missing = dir.file("missing.png");
  CHECK_THROWS_AS(read_png(missing), IoError);
  CHECK_THROWS_WITH(read_png(missing), Catch::Contains(missing));
  CHECK_THROWS_AS(read_png(dir.file("plain")), IoError);
  CHECK_THROWS_WITH(read_png(dir.file("plain")), Catch::Contains(dir.file("plain")));

  Image wrong{4, 4, std::vector<uint8_t>(10)};
  CHECK_THROWS_WITH(write_png(wrong, dir.file("wrong.png")),
                    Catch::Contains("wrong.png") && Catch::Contains("4x4"));
}
