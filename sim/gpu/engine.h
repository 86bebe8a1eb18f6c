// The GPU engine's common interface and its host implementation.
//
// Engine is what the parity checks drive: N worlds whose fields can be read and written through
// a float64 mirror in host memory (HostData<double>), a forward pass that runs every stage of
// the pipeline in order, and physics steps. HostEngine runs the same stage functions as the
// CUDA kernels, one world after another on the calling thread (the CI parity tests); the CUDA
// engine (device_engine.h) implements the same interface on the GPU.
#pragma once

#include <memory>
#include <string>

#include "sim/gpu/data.h"
#include "sim/gpu/model.h"

namespace bidex::sim::gpu {

class Engine {
 public:
  virtual ~Engine() = default;
  virtual int nworld() const = 0;
  virtual const Sizes& sizes() const = 0;
  // Where callers read and write fields (float64, world-major like the engine's own arrays).
  virtual HostData<double>& mirror() = 0;
  // Copies every field of the mirror into the engine / of the engine into the mirror.
  virtual void upload() = 0;
  virtual void download() = 0;
  // mj_forward's stages (no collision, no sensors), geom and site poses included.
  virtual void forward() = 0;
  // `n` physics steps (forward + Euler) of every world.
  virtual void step(int n) = 0;
  // Precision and where it runs, e.g. "host float64".
  virtual std::string describe() const = 0;
};

// The engine on the host, in precision T. With lanes > 1 every world is run by that many host
// threads meeting at barriers, as the lanes of a GPU world group do (a test of the kernels'
// lane logic, not a fast path).
template <class T>
class HostEngine : public Engine {
 public:
  HostEngine(const ModelArrays& arrays, int nworld, int lanes = 1);
  ~HostEngine() override;

  int nworld() const override { return nworld_; }
  const Sizes& sizes() const override { return model_.s; }
  HostData<double>& mirror() override;
  void upload() override;
  void download() override;
  void forward() override;
  void step(int n) override;
  std::string describe() const override;

  const Model<T>& model() const { return model_; }
  World<T> world(int w) const { return data_.world(w); }

 private:
  // runs fn(world, lanes) for every world, on `lanes_` threads per world when lanes_ > 1
  template <class F>
  void each_world(F fn);

  int nworld_;
  int lanes_;
  PackedModel<T> packed_;
  Model<T> model_;
  HostData<T> data_;
  std::unique_ptr<HostData<double>> mirror_;  // float only: the float64 mirror
};

// Copies every field between two layouts of the same sizes (precision converted).
template <class A, class B>
void copy_fields(const Data<A>& from, const Data<B>& to);

}  // namespace bidex::sim::gpu
