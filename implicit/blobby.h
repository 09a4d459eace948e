#pragma once
/// @file Blobby fields (the seed's "blobby objects", §3.6): a sum of radial kernels around balls,
/// compared with a threshold. value = threshold - sum(strength_i * kernel(|p - c_i| / R_i)), so the
/// solid (sum above threshold) is negative, as for every field. Not a distance.

#include <vector>

#include "implicit/field.h"

namespace isoforge::implicit {

enum class BlobKernel {
    Blinn,     ///< exp(-4 rho^2) (Blinn 1982), truncated where it falls below 1e-6 (rho = 1.86)
    Wyvill,    ///< soft objects: 1 - 4/9 rho^6 + 17/9 rho^4 - 22/9 rho^2 for rho < 1 (Wyvill et al. 1986)
    Metaball,  ///< Nishimura's piecewise quadratic: 1 - 3 rho^2, then 3/2 (1 - rho)^2, 0 beyond rho = 1
};

struct Ball {
    glm::vec3 centre{0.f};
    float radius = 1.f;    ///< the kernel's support (Blinn: its scale)
    float strength = 1.f;  ///< kernel weight (negative strengths carve)
};

/// @throw std::invalid_argument for no balls, non-positive radii or threshold.
FieldPtr makeBlobby(std::vector<Ball> balls, float threshold, BlobKernel kernel);

/// Kernel value at rho = r / R, and the rho beyond which it is zero (or negligible for Blinn).
float blobKernel(BlobKernel k, float rho);
float blobSupport(BlobKernel k);

}  // namespace isoforge::implicit
