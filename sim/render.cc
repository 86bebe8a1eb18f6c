#include "sim/render.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <initializer_list>
#include <mutex>
#include <string>

#include <dlfcn.h>
#include <mujoco/mujoco.h>

#include "core/error.h"
#include "core/files.h"

// One offscreen GL backend per build (cmake/BidexDependencies.cmake sets the define); only its
// headers are used here, its library is opened at run time. MuJoCo's GL loader takes the first of
// eglGetProcAddress, OSMesaGetProcAddress, glXGetProcAddressARB that the process's global symbols
// offer, once per process, so one backend only is ever loaded. With neither (BIDEX_RENDER_GL=NONE,
// or AUTO finding none) no GL header is included at all: the build needs no OpenGL packages.
#if defined(BIDEX_GL_OSMESA)
#include <GL/osmesa.h>
#elif defined(BIDEX_GL_EGL)
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GL/gl.h>
#endif
#if defined(BIDEX_HAVE_PNG)
#include <png.h>
#endif

namespace bidex::sim {

namespace {

constexpr int kMaxSide = 4096;

// ---------------------------------------------------------------------------------------------
// MuJoCo's errors. MuJoCo ends the process on an error unless mju_user_error leaves it. The
// first render chains a handler in front of whatever is installed: on a thread inside render()
// it throws bidex::Error; elsewhere it hands the message to the previous handler (SimBatch's,
// which throws), or, with none, does what MuJoCo would have done (report and exit).

thread_local bool t_rendering = false;
void (*g_previous_error)(const char*) = nullptr;

void render_error(const char* msg) {
  if (t_rendering) throw Error(std::string("render: MuJoCo: ") + msg);
  void (*previous)(const char*) = __atomic_load_n(&g_previous_error, __ATOMIC_ACQUIRE);
  if (previous) {
    previous(msg);
    return;
  }
  std::fprintf(stderr, "ERROR: %s\n", msg);
  std::exit(EXIT_FAILURE);
}

void install_error_handler() {
  static std::once_flag once;
  std::call_once(once, [] {
    // one atomic exchange: a handler set at the same moment elsewhere is chained, never lost
    void (*previous)(const char*) =
        __atomic_exchange_n(&mju_user_error, &render_error, __ATOMIC_ACQ_REL);
    __atomic_store_n(&g_previous_error, previous, __ATOMIC_RELEASE);
  });
}

struct RenderingScope {
  RenderingScope() { t_rendering = true; }
  ~RenderingScope() { t_rendering = false; }
};

// ---------------------------------------------------------------------------------------------
// The backend's library, opened at the first render rather than linked: a bidex binary then starts
// even where the backend (OSMesa brings LLVM) is missing, and only render() reports it. Opened
// RTLD_GLOBAL, because MuJoCo's loader looks its GetProcAddress up among the global symbols.

// Whether the space-separated `list` (of GL or EGL extensions) holds `word`.
[[maybe_unused]] bool has_word(const char* list, const char* word) {
  if (!list) return false;
  size_t n = std::strlen(word);
  for (const char* p = std::strstr(list, word); p; p = std::strstr(p + 1, word))
    if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
  return false;
}

[[maybe_unused]] void* open_library(std::initializer_list<const char*> names, std::string& error) {
  for (const char* name : names) {
    if (void* handle = dlopen(name, RTLD_NOW | RTLD_GLOBAL)) return handle;
    const char* why = dlerror();
    error += std::string(error.empty() ? "" : "; ") + (why ? why : name);
  }
  return nullptr;
}

// The functions of a backend, each a pointer named after the function it points to; `error`
// says why they could not be loaded (then render() throws it).
#define BIDEX_API_MEMBER(f) decltype(&::f) f = nullptr;
#define BIDEX_API_LOAD(f)                                                  \
  if (handle && !(api.f = reinterpret_cast<decltype(&::f)>(dlsym(handle, #f)))) \
    api.error = std::string(#f) + " is missing from the library";

#if defined(BIDEX_GL_OSMESA)

#define BIDEX_OSMESA_FUNCTIONS(X) \
  X(OSMesaCreateContextExt) X(OSMesaMakeCurrent) X(OSMesaDestroyContext) X(OSMesaGetProcAddress)

struct OsMesaApi {
  BIDEX_OSMESA_FUNCTIONS(BIDEX_API_MEMBER)
  std::string error;
};

const OsMesaApi& osmesa() {
  static const OsMesaApi loaded = [] {
    OsMesaApi api;
    void* handle = open_library({"libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so"}, api.error);
    if (!handle) api.error = "cannot load OSMesa (Debian: libosmesa6): " + api.error;
    else api.error.clear();
    BIDEX_OSMESA_FUNCTIONS(BIDEX_API_LOAD)
    return api;
  }();
  return loaded;
}

class GlContext {
 public:
  GlContext(int width, int height) : buffer_(static_cast<size_t>(width) * height * 4) {
    const OsMesaApi& api = osmesa();
    if (!api.error.empty()) throw Error("render: " + api.error);
    // MuJoCo's loader takes the first of EGL's, OSMesa's, GLX's GetProcAddress among the global
    // symbols, once per process
    if (dlsym(RTLD_DEFAULT, "eglGetProcAddress"))
      throw Error("render: libEGL is loaded into this process, so MuJoCo would take its GL "
                  "functions from EGL instead of OSMesa; build with -DBIDEX_RENDER_GL=EGL");
    ctx_ = api.OSMesaCreateContextExt(OSMESA_RGBA, 24, 8, 0, nullptr);
    if (!ctx_)
      throw Error("render: OSMesa could not create a GL context (OSMesaCreateContextExt failed)");
    if (!api.OSMesaMakeCurrent(ctx_, buffer_.data(), GL_UNSIGNED_BYTE, width, height)) {
      api.OSMesaDestroyContext(ctx_);
      throw Error("render: OSMesa could not make its GL context current");
    }
  }
  ~GlContext() {
    osmesa().OSMesaMakeCurrent(nullptr, nullptr, GL_UNSIGNED_BYTE, 0, 0);
    osmesa().OSMesaDestroyContext(ctx_);
  }
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  void* proc(const char* name) const {
    return reinterpret_cast<void*>(osmesa().OSMesaGetProcAddress(name));
  }

 private:
  std::vector<uint8_t> buffer_;  // OSMesa's own framebuffer; MuJoCo draws into its own FBO
  OSMesaContext ctx_ = nullptr;
};

#elif defined(BIDEX_GL_EGL)

#define BIDEX_EGL_FUNCTIONS(X)                                                                 \
  X(eglGetProcAddress) X(eglGetError) X(eglQueryString) X(eglGetDisplay) X(eglInitialize)      \
  X(eglTerminate) X(eglChooseConfig) X(eglBindAPI) X(eglCreateContext) X(eglDestroyContext)    \
  X(eglCreatePbufferSurface) X(eglDestroySurface) X(eglMakeCurrent)

struct EglApi {
  BIDEX_EGL_FUNCTIONS(BIDEX_API_MEMBER)
  std::string error;
};

const EglApi& egl() {
  static const EglApi loaded = [] {
    EglApi api;
    void* handle = open_library({"libEGL.so.1", "libEGL.so"}, api.error);
    if (!handle) api.error = "cannot load libEGL (Debian: libegl1 and libegl-mesa0): " + api.error;
    else api.error.clear();
    BIDEX_EGL_FUNCTIONS(BIDEX_API_LOAD)
    return api;
  }();
  return loaded;
}

class GlContext {
 public:
  GlContext(int width, int height) : api_(egl()) {
    if (!api_.error.empty()) throw Error("render: " + api_.error);
    open_display();
    const EGLint config_attribs[] = {EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8,
                                     EGL_DEPTH_SIZE, 24, EGL_STENCIL_SIZE, 8,
                                     EGL_SURFACE_TYPE, EGL_PBUFFER_BIT,
                                     EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
    EGLConfig config = nullptr;
    EGLint nconfig = 0;
    if (!api_.eglChooseConfig(dpy_, config_attribs, &config, 1, &nconfig) || nconfig < 1)
      fail("no RGB8 + depth24 + stencil8 OpenGL pbuffer config");
    if (!api_.eglBindAPI(EGL_OPENGL_API)) fail("cannot bind the desktop OpenGL API");
    ctx_ = api_.eglCreateContext(dpy_, config, EGL_NO_CONTEXT, nullptr);
    if (ctx_ == EGL_NO_CONTEXT) fail("cannot create an OpenGL context");
    // MuJoCo draws into its own framebuffer object: no surface, or a pbuffer without
    // EGL_KHR_surfaceless_context
    if (!has_word(api_.eglQueryString(dpy_, EGL_EXTENSIONS), "EGL_KHR_surfaceless_context")) {
      const EGLint pbuffer_attribs[] = {EGL_WIDTH, width, EGL_HEIGHT, height, EGL_NONE};
      surface_ = api_.eglCreatePbufferSurface(dpy_, config, pbuffer_attribs);
      if (surface_ == EGL_NO_SURFACE) fail("cannot create a pbuffer surface");
    }
    if (!api_.eglMakeCurrent(dpy_, surface_, surface_, ctx_))
      fail("cannot make the context current");
  }
  ~GlContext() { release(); }
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  void* proc(const char* name) const {
    return reinterpret_cast<void*>(api_.eglGetProcAddress(name));
  }

 private:
  std::string egl_error(const char* what) const {
    char code[16];
    std::snprintf(code, sizeof code, "0x%04x", static_cast<unsigned>(api_.eglGetError()));
    return std::string("render: EGL: ") + what + " (error " + code + ")";
  }
  // The first display that initialises: the first EGL device (a GPU when its driver offers EGL,
  // else Mesa's software device), Mesa's surfaceless platform, then the default display.
  void open_display() {
    const char* client = api_.eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
        api_.eglGetProcAddress("eglGetPlatformDisplayEXT"));
    auto query_devices =
        reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(api_.eglGetProcAddress("eglQueryDevicesEXT"));
    if (get_platform_display && query_devices && has_word(client, "EGL_EXT_platform_device")) {
      EGLDeviceEXT device = nullptr;
      EGLint ndevice = 0;
      if (query_devices(1, &device, &ndevice) && ndevice > 0 &&
          try_display(get_platform_display(EGL_PLATFORM_DEVICE_EXT, device, nullptr)))
        return;
    }
    if (get_platform_display && has_word(client, "EGL_MESA_platform_surfaceless") &&
        try_display(get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY,
                                         nullptr)))
      return;
    if (try_display(api_.eglGetDisplay(EGL_DEFAULT_DISPLAY))) return;
    throw Error(egl_error("no display could be initialised (tried the first EGL device, Mesa's "
                          "surfaceless platform and the default display)"));
  }
  bool try_display(EGLDisplay dpy) {
    EGLint major = 0, minor = 0;
    if (dpy == EGL_NO_DISPLAY || !api_.eglInitialize(dpy, &major, &minor)) return false;
    dpy_ = dpy;
    return true;
  }
  [[noreturn]] void fail(const char* what) {
    std::string msg = egl_error(what);
    release();
    throw Error(msg);
  }
  void release() {
    if (dpy_ == EGL_NO_DISPLAY) return;
    api_.eglMakeCurrent(dpy_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (surface_ != EGL_NO_SURFACE) api_.eglDestroySurface(dpy_, surface_);
    if (ctx_ != EGL_NO_CONTEXT) api_.eglDestroyContext(dpy_, ctx_);
    api_.eglTerminate(dpy_);
    dpy_ = EGL_NO_DISPLAY;
  }

  const EglApi& api_;
  EGLDisplay dpy_ = EGL_NO_DISPLAY;
  EGLContext ctx_ = EGL_NO_CONTEXT;
  EGLSurface surface_ = EGL_NO_SURFACE;
};

#else

class GlContext {
 public:
  GlContext(int, int) {
    throw Error("render: this build has no OpenGL rendering (configured with "
                "BIDEX_RENDER_GL=NONE, or AUTO found neither OSMesa nor EGL): install "
                "libosmesa6-dev (scripts/setup.sh) or libegl-dev and reconfigure with "
                "-DBIDEX_RENDER_GL=AUTO, OSMESA or EGL");
  }
};

// never reached: GlContext's constructor throws
int check_gl(const GlContext&, int, int) { return 0; }

#endif

#if defined(BIDEX_GL_OSMESA) || defined(BIDEX_GL_EGL)

// What MuJoCo's renderer needs of the context (it would end the process otherwise): OpenGL 1.5
// with framebuffer objects, renderbuffers of the image's size. Returns GL_MAX_SAMPLES.
int check_gl(const GlContext& gl, int width, int height) {
  using GetString = const GLubyte* (*)(GLenum);
  using GetIntegerv = void (*)(GLenum, GLint*);
  auto get_string = reinterpret_cast<GetString>(gl.proc("glGetString"));
  auto get_integer = reinterpret_cast<GetIntegerv>(gl.proc("glGetIntegerv"));
  if (!get_string || !get_integer)
    throw Error("render: the GL context offers no glGetString/glGetIntegerv");
  auto text = [&](GLenum e) {
    const GLubyte* s = get_string(e);
    return s ? std::string(reinterpret_cast<const char*>(s)) : std::string();
  };
  std::string version = text(GL_VERSION), renderer = text(GL_RENDERER);
  int major = 0, minor = 0;
  if (std::sscanf(version.c_str(), "%d.%d", &major, &minor) != 2 ||
      major * 10 + minor < 15)
    throw Error("render: MuJoCo needs OpenGL 1.5 or later, the context (" + renderer +
                ") offers '" + version + "'");
  if (!has_word(reinterpret_cast<const char*>(get_string(GL_EXTENSIONS)),
                "GL_ARB_framebuffer_object"))
    throw Error("render: MuJoCo needs GL_ARB_framebuffer_object, which the context (" +
                renderer + ", OpenGL " + version + ") lacks");
  GLint max_size = 0, max_samples = 0;
  get_integer(GL_MAX_RENDERBUFFER_SIZE, &max_size);
  get_integer(GL_MAX_SAMPLES, &max_samples);
  if (width > max_size || height > max_size)
    throw Error("render: " + std::to_string(width) + "x" + std::to_string(height) +
                " exceeds the context's largest renderbuffer (" + std::to_string(max_size) +
                " pixels a side, " + renderer + ")");
  return max_samples;
}

#endif

// ---------------------------------------------------------------------------------------------
// MuJoCo objects with their release.

struct DataPtr {
  mjData* d = nullptr;
  ~DataPtr() {
    if (d) mj_deleteData(d);
  }
};

// A private copy of `src` (or the initial pose when null) whose positions match its qpos.
void posed_copy(const mjModel* m, const mjData* src, DataPtr& out) {
  out.d = src ? mj_copyData(nullptr, m, src) : mj_makeData(m);
  if (!out.d) throw Error("render: MuJoCo could not allocate an mjData");
  mj_kinematics(m, out.d);
  mj_camlight(m, out.d);
}

struct SceneGuard {
  mjvScene scn;
  SceneGuard() { mjv_defaultScene(&scn); }
  ~SceneGuard() { mjv_freeScene(&scn); }
};

struct ContextGuard {
  mjrContext con;
  ContextGuard() { mjr_defaultContext(&con); }
  ~ContextGuard() { mjr_freeContext(&con); }  // while the GL context is still current
};

std::mutex g_render_mutex;

}  // namespace

const char* render_backend() {
#if defined(BIDEX_GL_OSMESA)
  return "osmesa";
#elif defined(BIDEX_GL_EGL)
  return "egl";
#else
  return "none";
#endif
}

Camera framing_camera(const SimModel& model, const mjData* data, double aspect) {
  if (!std::isfinite(aspect) || aspect <= 0)
    throw Error("framing_camera: the aspect (width / height) must be > 0, got " +
                std::to_string(aspect));
  const mjModel* m = model.mj();
  DataPtr posed;
  posed_copy(m, data, posed);
  const mjData* d = posed.d;

  // world-aligned bounding box of every geom but planes (infinite) and height fields
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (int g = 0; g < m->ngeom; ++g) {
    const mjtNum* size = m->geom_size + 3 * g;
    double e[3];  // half extents in the geom's frame
    switch (m->geom_type[g]) {
      case mjGEOM_SPHERE: e[0] = e[1] = e[2] = size[0]; break;
      case mjGEOM_CAPSULE: e[0] = e[1] = size[0], e[2] = size[0] + size[1]; break;
      case mjGEOM_CYLINDER: e[0] = e[1] = size[0], e[2] = size[1]; break;
      case mjGEOM_BOX:
      case mjGEOM_ELLIPSOID: e[0] = size[0], e[1] = size[1], e[2] = size[2]; break;
      case mjGEOM_PLANE:
      case mjGEOM_HFIELD: continue;
      default: e[0] = e[1] = e[2] = m->geom_rbound[g];  // meshes: their bounding sphere
    }
    const mjtNum* R = d->geom_xmat + 9 * g;  // row-major, columns are the geom's axes
    for (int k = 0; k < 3; ++k) {
      double half = std::abs(R[3 * k]) * e[0] + std::abs(R[3 * k + 1]) * e[1] +
                    std::abs(R[3 * k + 2]) * e[2];
      lo[k] = std::min(lo[k], d->geom_xpos[3 * g + k] - half);
      hi[k] = std::max(hi[k], d->geom_xpos[3 * g + k] + half);
    }
  }
  Camera cam;
  if (!(lo[0] <= hi[0])) {  // nothing but planes: MuJoCo's own default view of the model
    cam.lookat = {m->stat.center[0], m->stat.center[1], m->stat.center[2]};
    cam.distance = 1.5 * m->stat.extent;
    return cam;
  }
  for (int k = 0; k < 3; ++k) cam.lookat[k] = 0.5 * (lo[k] + hi[k]);
  // look across the longer horizontal side (square to it would be azimuth 0 or 90), turned 30
  // degrees so that depth shows, from 30 degrees above
  cam.azimuth_deg = hi[1] - lo[1] >= hi[0] - lo[0] ? 30.0 : 120.0;
  cam.elevation_deg = -30.0;

  // the nearest distance at which every corner of the box is inside the field of view (vertical:
  // the model's fovy; horizontal: as wide times `aspect`), with a 10% margin
  const double az = cam.azimuth_deg * M_PI / 180.0, el = cam.elevation_deg * M_PI / 180.0;
  const double fwd[3] = {std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)};
  const double right[3] = {std::sin(az), -std::cos(az), 0.0};
  const double up[3] = {right[1] * fwd[2] - right[2] * fwd[1], right[2] * fwd[0] - right[0] * fwd[2],
                        right[0] * fwd[1] - right[1] * fwd[0]};
  const double tv = 0.9 * std::tan(0.5 * m->vis.global.fovy * M_PI / 180.0), th = tv * aspect;
  double distance = 0.05;
  for (int corner = 0; corner < 8; ++corner) {
    double v[3];
    for (int k = 0; k < 3; ++k) v[k] = ((corner >> k) & 1 ? hi[k] : lo[k]) - cam.lookat[k];
    auto dot = [&](const double* a) { return a[0] * v[0] + a[1] * v[1] + a[2] * v[2]; };
    double depth = dot(fwd);
    distance =
        std::max({distance, std::abs(dot(right)) / th - depth, std::abs(dot(up)) / tv - depth});
  }
  cam.distance = distance;
  return cam;
}

Image render(const SimModel& model, const mjData* data, const RenderOptions& options) {
  const int w = options.width, h = options.height;
  if (w < 1 || h < 1 || w > kMaxSide || h > kMaxSide)
    throw Error("render: image size " + std::to_string(w) + "x" + std::to_string(h) +
                " is out of range (1 to " + std::to_string(kMaxSide) + " pixels a side)");
  const Camera& c = options.camera;
  if (!std::isfinite(c.distance) || c.distance <= 0 || !std::isfinite(c.azimuth_deg) ||
      !std::isfinite(c.elevation_deg) || !std::isfinite(c.lookat[0]) ||
      !std::isfinite(c.lookat[1]) || !std::isfinite(c.lookat[2]))
    throw Error("render: the camera needs a finite lookat, azimuth and elevation and a distance "
                "> 0, got distance " + std::to_string(c.distance));
  const mjModel* m = model.mj();

  std::lock_guard<std::mutex> lock(g_render_mutex);
  install_error_handler();
  RenderingScope scope;
  Image image;
  try {
    GlContext gl(w, h);
    int max_samples = check_gl(gl, w, h);

    // MuJoCo sizes its offscreen buffer from the model: a shallow copy of the model's struct
    // (same arrays, read only) carries this image's size and a sample count the context allows
    mjModel sized = *m;
    sized.vis.global.offwidth = w;
    sized.vis.global.offheight = h;
    sized.vis.quality.offsamples = std::clamp(sized.vis.quality.offsamples, 0, max_samples);

    DataPtr posed;
    posed_copy(m, data, posed);

    mjvOption opt;
    mjv_defaultOption(&opt);
    mjvCamera cam;
    mjv_defaultCamera(&cam);
    cam.type = mjCAMERA_FREE;
    for (int k = 0; k < 3; ++k) cam.lookat[k] = c.lookat[k];
    cam.distance = c.distance;
    cam.azimuth = c.azimuth_deg;
    cam.elevation = c.elevation_deg;

    SceneGuard scene;
    int maxgeom = 2 * (m->ngeom + m->nsite + m->nbody + m->ntendon + m->nlight + m->ncam) + 1000;
    mjv_makeScene(m, &scene.scn, maxgeom);
    ContextGuard context;
    mjr_makeContext(&sized, &context.con, mjFONTSCALE_100);
    mjr_setBuffer(mjFB_OFFSCREEN, &context.con);
    if (context.con.currentBuffer != mjFB_OFFSCREEN)
      throw Error("render: MuJoCo could not switch to its offscreen framebuffer");

    mjv_updateScene(m, posed.d, &opt, nullptr, &cam, mjCAT_ALL, &scene.scn);
    mjrRect viewport = {0, 0, w, h};
    mjr_render(viewport, &scene.scn, &context.con);

    // MuJoCo reads rows bottom to top
    std::vector<uint8_t> flipped(static_cast<size_t>(w) * h * 3);
    mjr_readPixels(flipped.data(), nullptr, viewport, &context.con);
    image.width = w;
    image.height = h;
    image.rgb.resize(flipped.size());
    const size_t row = static_cast<size_t>(w) * 3;
    for (int y = 0; y < h; ++y)
      std::memcpy(image.rgb.data() + row * y, flipped.data() + row * (h - 1 - y), row);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {  // e.g. SimBatch's MuJoCo error handler, installed later
    throw Error(std::string("render: MuJoCo: ") + e.what());
  }
  return image;
}

#if defined(BIDEX_HAVE_PNG)

void write_png(const Image& image, const std::string& path) {
  if (image.width < 1 || image.height < 1 ||
      image.rgb.size() != static_cast<size_t>(image.width) * image.height * 3)
    throw Error(path + ": cannot write a PNG of " + std::to_string(image.width) + "x" +
                std::to_string(image.height) + " pixels from " +
                std::to_string(image.rgb.size()) + " bytes (expected width * height * 3 > 0)");
  png_image png;
  std::memset(&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  png.width = static_cast<png_uint_32>(image.width);
  png.height = static_cast<png_uint_32>(image.height);
  png.format = PNG_FORMAT_RGB;
  png_alloc_size_t size = 0;  // first the size, then the bytes
  if (!png_image_write_to_memory(&png, nullptr, &size, 0, image.rgb.data(), 0, nullptr))
    throw IoError(path + ": cannot encode the PNG: " + png.message);
  std::string bytes(size, '\0');
  if (!png_image_write_to_memory(&png, bytes.data(), &size, 0, image.rgb.data(), 0, nullptr))
    throw IoError(path + ": cannot encode the PNG: " + png.message);
  bytes.resize(size);
  write_file_atomic(path, bytes);
}

Image read_png(const std::string& path) {
  std::string bytes = read_file(path);
  png_image png;
  std::memset(&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&png, bytes.data(), bytes.size()))
    throw IoError(path + ": not a readable PNG: " + png.message);
  png.format = PNG_FORMAT_RGB;
  Image image;
  image.width = static_cast<int>(png.width);
  image.height = static_cast<int>(png.height);
  image.rgb.assign(PNG_IMAGE_SIZE(png), 0);  // zero: any alpha is composed onto black
  if (!png_image_finish_read(&png, nullptr, image.rgb.data(), 0, nullptr))
    throw IoError(path + ": not a readable PNG: " + png.message);
  return image;
}

#else

void write_png(const Image&, const std::string& path) {
  throw Error(path + ": cannot write a PNG: this build has no libpng (install libpng-dev and "
                     "reconfigure)");
}

Image read_png(const std::string& path) {
  throw Error(path + ": cannot read a PNG: this build has no libpng (install libpng-dev and "
                     "reconfigure)");
}

#endif

}  // namespace bidex::sim
