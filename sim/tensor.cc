#include "sim/tensor.h"

#include <torch/torch.h>

#include "core/error.h"

namespace bidex::sim {

c10::Device default_device() {
  if (torch::cuda::is_available()) return c10::Device(c10::DeviceType::CUDA, 0);
  return c10::Device(c10::DeviceType::CPU);
}

at::Tensor to_tensor(const std::vector<double>& field, int nslot, int width,
                     const c10::Device& device) {
  if (field.size() != static_cast<size_t>(nslot) * width)
    throw std::invalid_argument("to_tensor: array of " + std::to_string(field.size()) +
                                " values is not " + std::to_string(nslot) + " x " +
                                std::to_string(width));
  // convert on the host, then one copy to the device
  auto host = torch::from_blob(const_cast<double*>(field.data()), {nslot, width},
                               torch::TensorOptions().dtype(torch::kFloat64))
                  .to(torch::kFloat32);
  if (device.is_cpu()) return host;
  return host.to(device);
}

void from_tensor(const at::Tensor& t, std::vector<double>& field, int nslot, int width) {
  if (t.dim() != 2 || t.size(0) != nslot || t.size(1) != width)
    throw std::invalid_argument("from_tensor: expected a tensor of shape [" +
                                std::to_string(nslot) + ", " + std::to_string(width) +
                                "], got " + c10::str(t.sizes()));
  auto host = t.detach().to(torch::kCPU, torch::kFloat64).contiguous();
  field.assign(host.data_ptr<double>(), host.data_ptr<double>() + static_cast<size_t>(nslot) * width);
}

}  // namespace bidex::sim
