// The bridge from batch arrays to LibTorch tensors: learning code sees only tensors, on the GPU
// when LibTorch was built with CUDA. Include only where tensors are needed (it pulls in ATen).
#pragma once

#include <vector>

#include <ATen/core/Tensor.h>
#include <c10/core/Device.h>

namespace bidex::sim {

// CUDA:0 when this LibTorch has CUDA and a device is visible, else the CPU.
c10::Device default_device();

// Copies a (nslot, width) batch array into a float32 tensor on `device`: one host-side
// conversion, one transfer.
at::Tensor to_tensor(const std::vector<double>& field, int nslot, int width,
                     const c10::Device& device);

// Copies a (nslot, width) tensor (any device, any floating type) into a batch array.
void from_tensor(const at::Tensor& t, std::vector<double>& field, int nslot, int width);

}  // namespace bidex::sim
