// sim/tensor: batch arrays to float32 tensors and back.
#include "sim/tensor.h"

#include <cmath>
#include <stdexcept>

#include <catch2/catch.hpp>

TEST_CASE("to_tensor and from_tensor round-trip a batch array", "[sim][tensor]") {
  const int nslot = 3, width = 4;
  std::vector<double> field;
  for (int i = 0; i < nslot * width; ++i) field.push_back(0.1 * i - 0.5);
  c10::Device cpu(c10::DeviceType::CPU);
  at::Tensor t = bidex::sim::to_tensor(field, nslot, width, cpu);
  REQUIRE(t.dim() == 2);
  CHECK(t.size(0) == nslot);
  CHECK(t.size(1) == width);
  CHECK(t.scalar_type() == at::kFloat);
  CHECK(t.is_contiguous());
  const float* p = t.data_ptr<float>();
  for (int i = 0; i < nslot * width; ++i) CHECK(p[i] == static_cast<float>(field[i]));

  std::vector<double> back(1, 123.0);  // resized by from_tensor
  bidex::sim::from_tensor(t, back, nslot, width);
  REQUIRE(back.size() == field.size());
  for (size_t i = 0; i < field.size(); ++i)
    CHECK(back[i] == static_cast<double>(static_cast<float>(field[i])));
}

TEST_CASE("tensor conversions check shapes", "[sim][tensor]") {
  std::vector<double> field(6, 1.0);
  c10::Device cpu(c10::DeviceType::CPU);
  CHECK_THROWS_AS(bidex::sim::to_tensor(field, 4, 2, cpu), std::invalid_argument);
  at::Tensor t = bidex::sim::to_tensor(field, 2, 3, cpu);
  std::vector<double> out;
  try {
    bidex::sim::from_tensor(t, out, 3, 2);
    FAIL("no error");
  } catch (const std::invalid_argument& e) {
    std::string what = e.what();
    CHECK(what.find("[3, 2]") != std::string::npos);
    CHECK(what.find("[2, 3]") != std::string::npos);
  }
}

TEST_CASE("the default device is described", "[sim][tensor]") {
  c10::Device d = bidex::sim::default_device();
  std::string s = d.str();
  if (d.is_cpu()) CHECK(s == "cpu");
  else CHECK(s.rfind("cuda", 0) == 0);
}
