// Host/device marking for per-slot code that is written once and compiled for both sides:
// BIDEX_HD is __host__ __device__ under nvcc and empty for the host compiler.
#pragma once

#if defined(__CUDACC__)
#define BIDEX_HD __host__ __device__
#else
#define BIDEX_HD
#endif
