#include "render/embree_renderer.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <glm/geometric.hpp>

#include "core/progress.h"
#include "render/embree_device.h"
#include "render/shading.h"

namespace isoforge::render {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

struct SceneRelease {
    void operator()(RTCScene s) const {
        if (s) rtcReleaseScene(s);
    }
};
using ScenePtr = std::unique_ptr<std::remove_pointer_t<RTCScene>, SceneRelease>;

/// What shading needs per object, beside Embree's copy of the geometry.
struct ObjectData {
    const mesh::TriMesh* mesh;
    std::vector<glm::vec3> normals;  ///< per vertex, unit
    implicit::Material material;
    glm::vec3 albedo;  ///< linear
    bool vertexColors;
    float offset = 0;  ///< secondary rays start this far off the surface: a quarter of the mean edge
};

void attachMesh(RTCDevice device, RTCScene scene, const mesh::TriMesh& m) {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    // Embree's own buffers: padded as its SIMD loads need.
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                          3 * sizeof(float), m.positions.size()));
    for (std::size_t i = 0; i < m.positions.size(); ++i) {
        v[3 * i] = m.positions[i].x;
        v[3 * i + 1] = m.positions[i].y;
        v[3 * i + 2] = m.positions[i].z;
    }
    auto* t = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                             3 * sizeof(unsigned), m.triangles.size()));
    for (std::size_t i = 0; i < m.triangles.size(); ++i) {
        t[3 * i] = m.triangles[i].x;
        t[3 * i + 1] = m.triangles[i].y;
        t[3 * i + 2] = m.triangles[i].z;
    }
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
}

std::vector<glm::vec3> vertexNormals(const mesh::TriMesh& m) {
    if (m.normals.size() == m.positions.size()) return m.normals;
    std::vector<glm::vec3> n(m.positions.size(), glm::vec3(0.f));
    for (const auto& t : m.triangles) {
        const glm::vec3 a = glm::cross(m.positions[t.y] - m.positions[t.x], m.positions[t.z] - m.positions[t.x]);
        n[t.x] += a;
        n[t.y] += a;
        n[t.z] += a;
    }
    for (auto& v : n) {
        const float l = glm::length(v);
        v = l > 0 ? v / l : glm::vec3(0, 0, 1);
    }
    return n;
}

}  // namespace

Frame renderMeshes(const std::vector<MeshObject>& objects, const Look& look, const RenderOptions& o,
                   RenderStats* stats) {
    const auto t0 = std::chrono::steady_clock::now();
    if (o.width <= 0 || o.height <= 0) throw std::invalid_argument("image size must be positive");
    DevicePtr device = makeDevice();
    ScenePtr all(rtcNewScene(device.get())), opaque(rtcNewScene(device.get()));
    rtcSetSceneBuildQuality(all.get(), RTC_BUILD_QUALITY_HIGH);
    rtcSetSceneFlags(all.get(), RTC_SCENE_FLAG_ROBUST);  // watertight: no ray slips between two triangles
    rtcSetSceneFlags(opaque.get(), RTC_SCENE_FLAG_ROBUST);
    std::vector<ObjectData> data;
    bool anyTranslucent = false;
    implicit::Box3 box;
    for (const MeshObject& obj : objects) {
        if (!obj.mesh || obj.mesh->triangles.empty()) continue;
        for (const auto& p : obj.mesh->positions) box = box.unite(implicit::Box3{p, p});
        attachMesh(device.get(), all.get(), *obj.mesh);
        ObjectData d{obj.mesh, vertexNormals(*obj.mesh), obj.material, srgbToLinear(glm::vec3(obj.material.color)),
                     obj.vertexColors && obj.mesh->colors.size() == obj.mesh->positions.size()};
        if (obj.material.color.a < 1.f) anyTranslucent = true;
        data.push_back(std::move(d));
    }
    // Shadows come from opaque objects only (translucent layers let light through).
    if (anyTranslucent)
        for (const ObjectData& d : data)
            if (d.material.color.a >= 1.f) attachMesh(device.get(), opaque.get(), *d.mesh);
    rtcCommitScene(all.get());
    if (anyTranslucent) rtcCommitScene(opaque.get());
    RTCScene shadowScene = anyTranslucent ? opaque.get() : all.get();
    const double setup = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    const std::vector<Light> lights = look.lights.empty() ? defaultLights(look.camera) : look.lights;
    const detail::Background background(look);
    const float sceneSize = box.isEmpty() ? 1.f : glm::length(box.size());
    const float aoReach = o.aoDistance > 0 ? o.aoDistance : 0.05f * sceneSize;
    const float eps = 1e-5f * sceneSize;
    auto occluded = [&](const glm::vec3& origin, const glm::vec3& d, float tfar) {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        RTCRay r;
        r.org_x = origin.x;
        r.org_y = origin.y;
        r.org_z = origin.z;
        r.dir_x = d.x;
        r.dir_y = d.y;
        r.dir_z = d.z;
        r.tnear = 0.f;
        r.tfar = tfar;
        r.mask = 0xFFFFFFFFu;
        r.flags = 0;
        r.time = 0.f;
        rtcOccluded1(shadowScene, &ctx, &r);
        return r.tfar < 0.f;
    };
    auto trace = [&](const detail::Ray& ray, std::size_t pix, std::size_t s, float py) {
        detail::SampleResult out;
        glm::vec3 acc(0.f);
        float transmit = 1.f, tmin = 0.f;
        RTCIntersectContext ctx;
        for (int layer = 0; layer < 16 && transmit > 0.004f; ++layer) {
            RTCRayHit rh;
            rh.ray.org_x = ray.origin.x;
            rh.ray.org_y = ray.origin.y;
            rh.ray.org_z = ray.origin.z;
            rh.ray.dir_x = ray.dir.x;
            rh.ray.dir_y = ray.dir.y;
            rh.ray.dir_z = ray.dir.z;
            rh.ray.tnear = tmin;
            rh.ray.tfar = kInf;
            rh.ray.mask = 0xFFFFFFFFu;
            rh.ray.flags = 0;
            rh.ray.time = 0.f;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            rtcInitIntersectContext(&ctx);
            rtcIntersect1(all.get(), &ctx, &rh);
            if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) break;
            const ObjectData& od = data[rh.hit.geomID];
            const glm::uvec3 tri = od.mesh->triangles[rh.hit.primID];
            const float u = rh.hit.u, v = rh.hit.v, w = 1.f - u - v;
            detail::Surface surf;
            surf.position = ray.origin + rh.ray.tfar * ray.dir;
            glm::vec3 n = w * od.normals[tri.x] + u * od.normals[tri.y] + v * od.normals[tri.z];
            const float nl = glm::length(n);
            n = nl > 0 ? n / nl : glm::normalize(glm::vec3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z));
            if (glm::dot(n, ray.dir) > 0) n = -n;  // seen from behind: shade the side we see
            surf.normal = n;
            surf.albedo =
                od.vertexColors
                    ? srgbToLinear(w * od.mesh->colors[tri.x] + u * od.mesh->colors[tri.y] + v * od.mesh->colors[tri.z])
                    : od.albedo;
            surf.opacity = od.material.color.a;
            surf.diffuse = od.material.diffuse;
            surf.specular = od.material.specular;
            surf.shininess = od.material.shininess;
            const glm::vec3 origin = surf.position + n * (eps + od.offset + 1e-5f * rh.ray.tfar);
            auto visible = [&](std::size_t li, const glm::vec3& L) {
                if (!o.shadows) return true;
                return !occluded(origin, L, lights[li].point ? glm::length(lights[li].vector - origin) : kInf);
            };
            const float ao = detail::ambientOcclusion(
                n, o.aoSamples, static_cast<std::uint32_t>(pix * 64u + s * 16u + static_cast<std::size_t>(layer)),
                [&](const glm::vec3& d) { return !occluded(origin, d, aoReach); });
            acc += transmit * surf.opacity * detail::shade(surf, ray.dir, lights, look.ambient, ao, visible);
            if (!out.hit) {
                out.hit = true;
                out.depth = rh.ray.tfar;
                out.normal = n;
                out.id = float(rh.hit.geomID + 1);
            }
            transmit *= 1.f - surf.opacity;
            tmin = rh.ray.tfar + eps + 1e-4f * rh.ray.tfar;
        }
        out.color = acc + transmit * background.at(py, o.height);
        return out;
    };
    std::uint64_t hitPixels = 0;
    Frame f = detail::renderTiles(look, o, trace, hitPixels);
    if (stats) {
        stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        stats->setupSeconds = setup;
        stats->primaryRays = f.pixels() * static_cast<std::size_t>(std::max(o.spp, 1));
        stats->hitPixels = hitPixels;
        if (data.empty()) stats->warnings.push_back("nothing to render: no triangles");
    }
    return f;
}

}  // namespace isoforge::render
