#include "implicit/blobby.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

namespace isoforge::implicit {

namespace {
constexpr float kBlinnEpsilon = 1e-6f;  // Blinn kernels are cut where below this
}

float blobSupport(BlobKernel k) {
    return k == BlobKernel::Blinn ? std::sqrt(-std::log(kBlinnEpsilon) / 4.f) : 1.f;
}

float blobKernel(BlobKernel k, float rho) {
    switch (k) {
        case BlobKernel::Blinn:
            return rho < blobSupport(k) ? std::exp(-4.f * rho * rho) : 0.f;
        case BlobKernel::Wyvill: {
            if (rho >= 1.f) return 0.f;
            const float r2 = rho * rho, r4 = r2 * r2, r6 = r4 * r2;
            return 1.f - (4.f / 9.f) * r6 + (17.f / 9.f) * r4 - (22.f / 9.f) * r2;
        }
        case BlobKernel::Metaball:
            if (rho <= 1.f / 3.f) return 1.f - 3.f * rho * rho;
            if (rho < 1.f) return 1.5f * (1.f - rho) * (1.f - rho);
            return 0.f;
    }
    return 0.f;
}

namespace {

class Blobby final : public Field {
public:
    Blobby(std::vector<Ball> balls, float threshold, BlobKernel kernel, float cutSlack)
        : balls_(std::move(balls)), threshold_(threshold), kernel_(kernel), slack_(cutSlack) {
        support_ = blobSupport(kernel);
    }
    float value(const glm::vec3& p) const override {
        float sum = 0.f;
        for (const Ball& b : balls_) sum += b.strength * blobKernel(kernel_, glm::length(p - b.centre) / b.radius);
        return threshold_ - sum;
    }
    void values(std::span<const glm::vec3> p, std::span<float> out) const override {
        for (std::size_t i = 0; i < p.size(); ++i) out[i] = threshold_;
        for (const Ball& b : balls_) {
            const float inv = 1.f / b.radius;
            for (std::size_t i = 0; i < p.size(); ++i)
                out[i] -= b.strength * blobKernel(kernel_, glm::length(p[i] - b.centre) * inv);
        }
    }
    Interval bound(const Box3& box) const override {
        // Each kernel decreases with distance: its range over the box comes from the nearest and
        // farthest points of the box from the centre. Dropped Blinn tails add at most slack_.
        Interval sum(0.f);
        for (const Ball& b : balls_) {
            const glm::vec3 near = glm::clamp(b.centre, box.min, box.max);
            const glm::vec3 far = glm::max(glm::abs(b.centre - box.min), glm::abs(b.centre - box.max));
            const float kNear = blobKernel(kernel_, glm::length(near - b.centre) / b.radius);
            const float kFar = blobKernel(kernel_, glm::length(far) / b.radius);
            sum = sum + Interval(b.strength) * Interval(kFar, kNear);
        }
        return Interval(threshold_) - sum - Interval(-slack_, slack_);
    }
    Box3 bounds() const override {
        // Where the sum can reach the threshold: within the support of some positive ball.
        Box3 b;
        for (const Ball& ball : balls_)
            if (ball.strength > 0) {
                const float r = ball.radius * support_;
                b = b.unite(Box3{ball.centre - glm::vec3(r), ball.centre + glm::vec3(r)});
            }
        return b;
    }
    bool isDistance() const override { return false; }
    FieldPtr simplify(const Box3& box) const override {
        // Keep only the balls whose support reaches the box.
        std::vector<Ball> near;
        float dropped = slack_;
        for (const Ball& b : balls_) {
            const glm::vec3 q = glm::clamp(b.centre, box.min, box.max);
            if (glm::length(q - b.centre) < b.radius * support_)
                near.push_back(b);
            else if (kernel_ == BlobKernel::Blinn)
                dropped += std::abs(b.strength) * kBlinnEpsilon;
        }
        if (near.size() == balls_.size()) return nullptr;
        if (near.empty()) near.push_back({box.centre(), 1e-3f, 0.f});  // a zero ball keeps the field valid
        return std::make_shared<Blobby>(std::move(near), threshold_, kernel_, dropped);
    }
    std::string describe() const override {
        static const char* names[] = {"blinn", "wyvill", "metaball"};
        std::ostringstream s;
        s << "blobby(" << names[static_cast<int>(kernel_)] << ", threshold=" << threshold_ << ", " << balls_.size()
          << " balls)";
        return s.str();
    }

private:
    std::vector<Ball> balls_;
    float threshold_;
    BlobKernel kernel_;
    float slack_;
    float support_ = 1.f;
};

}  // namespace

FieldPtr makeBlobby(std::vector<Ball> balls, float threshold, BlobKernel kernel) {
    if (balls.empty()) throw std::invalid_argument("blobby: no balls");
    if (!(threshold > 0)) throw std::invalid_argument("blobby: the threshold must be positive");
    for (const Ball& b : balls)
        if (!(b.radius > 0)) throw std::invalid_argument("blobby: ball radii must be positive");
    return std::make_shared<Blobby>(std::move(balls), threshold, kernel, 0.f);
}

}  // namespace isoforge::implicit
