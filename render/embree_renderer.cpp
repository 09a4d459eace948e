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

struct PreparedMeshes::Impl {
    DevicePtr device;
    ScenePtr all, opaque;
    std::vector<ObjectData> data;
    bool anyTranslucent = false;
    implicit::Box3 box;
    double setupSeconds = 0;
};

PreparedMeshes::PreparedMeshes(const std::vector<MeshObject>& objects) : impl_(std::make_unique<Impl>()) {
    const auto t0 = std::chrono::steady_clock::now();
    Impl& im = *impl_;
    im.device = makeDevice();
    im.all.reset(rtcNewScene(im.device.get()));
    im.opaque.reset(rtcNewScene(im.device.get()));
    rtcSetSceneBuildQuality(im.all.get(), RTC_BUILD_QUALITY_HIGH);
    rtcSetSceneFlags(im.all.get(), RTC_SCENE_FLAG_ROBUST);  // watertight: no ray slips between two triangles
    rtcSetSceneFlags(im.opaque.get(), RTC_SCENE_FLAG_ROBUST);
    for (const MeshObject& obj : objects) {
        if (!obj.mesh || obj.mesh->triangles.empty()) continue;
        for (const auto& p : obj.mesh->positions) im.box = im.box.unite(implicit::Box3{p, p});
        attachMesh(im.device.get(), im.all.get(), *obj.mesh);
        ObjectData d{obj.mesh, vertexNormals(*obj.mesh), obj.material, srgbToLinear(glm::vec3(obj.material.color)),
                     obj.vertexColors && obj.mesh->colors.size() == obj.mesh->positions.size()};
        double edges = 0;  // the mean edge, for the offset of secondary rays
        for (const glm::uvec3& t : obj.mesh->triangles)
            edges += double(glm::length(obj.mesh->positions[t.y] - obj.mesh->positions[t.x])) +
                     glm::length(obj.mesh->positions[t.z] - obj.mesh->positions[t.y]) +
                     glm::length(obj.mesh->positions[t.x] - obj.mesh->positions[t.z]);
        d.offset = float(0.25 * edges / (3.0 * double(obj.mesh->triangles.size())));
        if (obj.material.color.a < 1.f) im.anyTranslucent = true;
        im.data.push_back(std::move(d));
    }
    // Shadows come from opaque objects only (translucent layers let light through).
    if (im.anyTranslucent)
        for (const ObjectData& d : im.data)
            if (d.material.color.a >= 1.f) attachMesh(im.device.get(), im.opaque.get(), *d.mesh);
    rtcCommitScene(im.all.get());
    if (im.anyTranslucent) rtcCommitScene(im.opaque.get());
    im.setupSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

PreparedMeshes::~PreparedMeshes() = default;

double PreparedMeshes::setupSeconds() const {
    return impl_->setupSeconds;
}

Frame PreparedMeshes::render(const Look& look, const RenderOptions& o, RenderStats* stats) const {
    const auto t0 = std::chrono::steady_clock::now();
    if (o.width <= 0 || o.height <= 0) throw std::invalid_argument("image size must be positive");
    const std::vector<ObjectData>& data = impl_->data;
    RTCScene allScene = impl_->all.get();
    RTCScene shadowScene = impl_->anyTranslucent ? impl_->opaque.get() : allScene;
    const implicit::Box3& box = impl_->box;
    const detail::LightSet lights(look);
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
            rtcIntersect1(allScene, &ctx, &rh);
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
            surf.setMaterial(od.material);
            const glm::vec3 origin = surf.position + n * (eps + od.offset + 1e-5f * rh.ray.tfar);
            acc += transmit * surf.opacity *
                   detail::shadeHit(surf, origin, ray.dir, look, lights, o, aoReach,
                                    static_cast<std::uint32_t>(pix * 64u + s * 16u + static_cast<std::size_t>(layer)),
                                    occluded);
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
    // Opaque first hits go through Embree's 16-wide packets (primary rays of a 4x4 pixel block, then
    // one shadow packet per light); lanes whose first hit is translucent take the one-ray path above.
    auto traceBlock = [&](const detail::Ray* rays, int n, const std::size_t* pix, std::size_t s, const float* py,
                          detail::SampleResult* out) {
        alignas(64) int valid[16];
        alignas(64) RTCRayHit16 rh;
        for (int k = 0; k < 16; ++k) {
            const detail::Ray& r = rays[k < n ? k : 0];
            valid[k] = k < n ? -1 : 0;
            rh.ray.org_x[k] = r.origin.x;
            rh.ray.org_y[k] = r.origin.y;
            rh.ray.org_z[k] = r.origin.z;
            rh.ray.dir_x[k] = r.dir.x;
            rh.ray.dir_y[k] = r.dir.y;
            rh.ray.dir_z[k] = r.dir.z;
            rh.ray.tnear[k] = 0.f;
            rh.ray.tfar[k] = kInf;
            rh.ray.mask[k] = 0xFFFFFFFFu;
            rh.ray.flags[k] = 0;
            rh.ray.time[k] = 0.f;
            rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
        }
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
        rtcIntersect16(valid, allScene, &ctx, &rh);
        detail::Surface surf[16];
        glm::vec3 origin[16];
        bool opaqueHit[16] = {};
        for (int k = 0; k < n; ++k) {
            const unsigned g = rh.hit.geomID[k];
            if (g == RTC_INVALID_GEOMETRY_ID) {
                out[k].color = background.at(py[k], o.height);
                continue;
            }
            const ObjectData& od = data[g];
            if (od.material.color.a < 1.f) {
                out[k] = trace(rays[k], pix[k], s, py[k]);
                continue;
            }
            const glm::uvec3 tri = od.mesh->triangles[rh.hit.primID[k]];
            const float u = rh.hit.u[k], v = rh.hit.v[k], w = 1.f - u - v, t = rh.ray.tfar[k];
            detail::Surface& sf = surf[k];
            sf.position = rays[k].origin + t * rays[k].dir;
            glm::vec3 nrm = w * od.normals[tri.x] + u * od.normals[tri.y] + v * od.normals[tri.z];
            const float nl = glm::length(nrm);
            nrm = nl > 0 ? nrm / nl : glm::normalize(glm::vec3(rh.hit.Ng_x[k], rh.hit.Ng_y[k], rh.hit.Ng_z[k]));
            if (glm::dot(nrm, rays[k].dir) > 0) nrm = -nrm;
            sf.normal = nrm;
            sf.albedo =
                od.vertexColors
                    ? srgbToLinear(w * od.mesh->colors[tri.x] + u * od.mesh->colors[tri.y] + v * od.mesh->colors[tri.z])
                    : od.albedo;
            sf.setMaterial(od.material);
            origin[k] = sf.position + nrm * (eps + od.offset + 1e-5f * t);
            opaqueHit[k] = true;
            out[k].hit = true;
            out[k].depth = t;
            out[k].normal = nrm;
            out[k].id = float(g + 1);
        }
        // Shadow packets: bit k of visible[l] set when light l reaches lane k.
        std::uint32_t visibleMask[8] = {};
        const std::size_t packetLights = std::min<std::size_t>(lights.size(), 8);
        for (std::size_t li = 0; li < packetLights; ++li) {
            if (!o.shadows) {
                visibleMask[li] = 0xFFFFu;
                continue;
            }
            alignas(64) int sv[16];
            alignas(64) RTCRay16 sr;
            bool any = false;
            for (int k = 0; k < 16; ++k) {
                sv[k] = 0;
                sr.org_x[k] = sr.org_y[k] = sr.org_z[k] = 0.f;
                sr.dir_x[k] = sr.dir_y[k] = 0.f;
                sr.dir_z[k] = 1.f;
                sr.tnear[k] = 0.f;
                sr.tfar[k] = kInf;
                sr.mask[k] = 0xFFFFFFFFu;
                sr.flags[k] = 0;
                sr.time[k] = 0.f;
                if (!opaqueHit[k]) continue;
                const glm::vec3 L = lights.towards(li, surf[k].position);
                if (glm::dot(surf[k].normal, L) <= 0.f) continue;
                sv[k] = -1;
                any = true;
                sr.org_x[k] = origin[k].x;
                sr.org_y[k] = origin[k].y;
                sr.org_z[k] = origin[k].z;
                sr.dir_x[k] = L.x;
                sr.dir_y[k] = L.y;
                sr.dir_z[k] = L.z;
                sr.tfar[k] = lights.reach(li, origin[k]);
            }
            if (!any) continue;
            RTCIntersectContext sctx;
            rtcInitIntersectContext(&sctx);
            sctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;  // a 4x4 block's rays towards one light
            rtcOccluded16(sv, shadowScene, &sctx, &sr);
            for (int k = 0; k < 16; ++k)
                if (sv[k] && sr.tfar[k] >= 0.f) visibleMask[li] |= 1u << k;
        }
        for (int k = 0; k < n; ++k) {
            if (!opaqueHit[k]) continue;
            const float ao = detail::ambientOcclusion(
                surf[k].normal, o.aoSamples, static_cast<std::uint32_t>(pix[k] * 64u + s * 16u),
                [&](const glm::vec3& d) { return !occluded(origin[k], d, aoReach); });
            auto visible = [&](std::size_t li, const glm::vec3& L) {
                if (li < packetLights) return ((visibleMask[li] >> k) & 1u) != 0;
                return !o.shadows || !occluded(origin[k], L, lights.reach(li, origin[k]));
            };
            out[k].color = detail::shade(surf[k], rays[k].dir, lights, look.ambient, ao, visible);
        }
    };
    std::uint64_t hitPixels = 0;
    Frame f = detail::renderBlocks(look, o, traceBlock, hitPixels);
    if (stats) {
        stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        stats->primaryRays = f.pixels() * static_cast<std::size_t>(std::max(o.spp, 1));
        stats->hitPixels = hitPixels;
        if (data.empty()) stats->warnings.push_back("nothing to render: no triangles");
    }
    return f;
}

Frame renderMeshes(const std::vector<MeshObject>& objects, const Look& look, const RenderOptions& options,
                   RenderStats* stats) {
    if (options.width <= 0 || options.height <= 0) throw std::invalid_argument("image size must be positive");
    const PreparedMeshes prepared(objects);
    Frame f = prepared.render(look, options, stats);
    if (stats) {
        stats->setupSeconds = prepared.setupSeconds();
        stats->seconds += prepared.setupSeconds();
    }
    return f;
}

}  // namespace isoforge::render
