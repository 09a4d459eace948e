#include "render/embree_renderer.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
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

std::vector<mesh::TriMesh> splitByMaterial(const mesh::TriMesh& m, const implicit::Field& field,
                                           std::vector<implicit::Material>& materials) {
    std::vector<const implicit::Material*> tag(m.triangles.size());
    if (field.hasMaterial())
        tbb::parallel_for(std::size_t{0}, m.triangles.size(), [&](std::size_t i) {
            const auto& t = m.triangles[i];
            tag[i] = field.materialAt((m.positions[t.x] + m.positions[t.y] + m.positions[t.z]) / 3.f);
        });
    // Materials in order of first use: deterministic.
    std::map<const implicit::Material*, std::size_t> slot;
    std::vector<mesh::TriMesh> out;
    std::vector<std::vector<std::uint32_t>> remap;
    for (std::size_t i = 0; i < m.triangles.size(); ++i) {
        auto [it, added] = slot.try_emplace(tag[i], out.size());
        if (added) {
            out.emplace_back();
            remap.emplace_back(m.positions.size(), UINT32_MAX);
            materials.push_back(tag[i] ? *tag[i] : implicit::Material{});
        }
        mesh::TriMesh& o = out[it->second];
        auto& r = remap[it->second];
        glm::uvec3 t;
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t v = m.triangles[i][k];
            if (r[v] == UINT32_MAX) {
                r[v] = static_cast<std::uint32_t>(o.positions.size());
                o.positions.push_back(m.positions[v]);
                if (!m.normals.empty()) o.normals.push_back(m.normals[v]);
            }
            t[k] = r[v];
        }
        o.triangles.push_back(t);
    }
    return out;
}

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
            const glm::vec3 ng(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
            n = nl > 0 ? n / nl : glm::normalize(ng);
            // Seen from behind (by the triangle's own normal): shade the side we see. The smooth normal
            // can still lean away from the viewer on a triangle that faces it (at creases): it is bent
            // towards the viewer, not reversed (reversed, it shaded the pixel as if facing the floor).
            if (glm::dot(ng, ray.dir) > 0) n = -n;
            n = detail::bendTowardsViewer(n, ray.dir);
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
    // one shadow packet per light) and are shaded as structure of arrays, in loops over the 16 lanes
    // that the compiler vectorizes; lanes whose first hit is translucent take the one-ray path above.
    const std::size_t packetLights = std::min<std::size_t>(lights.size(), 8);
    auto traceBlock = [&](const detail::RayBlock& rays, int n, const std::size_t* pix, std::size_t s, const float* py,
                          detail::SampleResult* out) {
        alignas(64) int valid[16];
        alignas(64) RTCRayHit16 rh;
        std::memcpy(rh.ray.org_x, rays.ox, sizeof rays.ox);
        std::memcpy(rh.ray.org_y, rays.oy, sizeof rays.oy);
        std::memcpy(rh.ray.org_z, rays.oz, sizeof rays.oz);
        std::memcpy(rh.ray.dir_x, rays.dx, sizeof rays.dx);
        std::memcpy(rh.ray.dir_y, rays.dy, sizeof rays.dy);
        std::memcpy(rh.ray.dir_z, rays.dz, sizeof rays.dz);
        // One simple loop per field: each becomes a few vector stores.
        for (int k = 0; k < 16; ++k) valid[k] = k < n ? -1 : 0;
        std::fill_n(rh.ray.tnear, 16, 0.f);
        std::fill_n(rh.ray.tfar, 16, kInf);
        std::fill_n(rh.ray.mask, 16, 0xFFFFFFFFu);
        std::fill_n(rh.ray.flags, 16, 0u);
        std::fill_n(rh.ray.time, 16, 0.f);
        std::fill_n(rh.hit.geomID, 16, RTC_INVALID_GEOMETRY_ID);
        std::fill_n(rh.hit.instID[0], 16, RTC_INVALID_GEOMETRY_ID);
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
        rtcIntersect16(valid, allScene, &ctx, &rh);

        // Per lane: the corner normals and the material of its opaque hit (other lanes get harmless
        // values, so that the loops below may run over all 16).
        alignas(64) float n0x[16], n0y[16], n0z[16], n1x[16], n1y[16], n1z[16], n2x[16], n2y[16], n2z[16], off[16];
        detail::HitLanes h;
        h.clear();
        int opaqueCount = 0;
        // The hit triangles' indices first, all lanes at once (independent loads: their cache
        // misses overlap instead of each waiting for the one before).
        glm::uvec3 tris[16];
        for (int k = 0; k < n; ++k) {
            const unsigned g = rh.hit.geomID[k];
            if (g != RTC_INVALID_GEOMETRY_ID) tris[k] = data[g].mesh->triangles[rh.hit.primID[k]];
        }
        for (float* a : {n0x, n0y, n1x, n1y, n2x, n2y, off}) std::fill_n(a, 16, 0.f);
        for (float* a : {n0z, n1z, n2z}) std::fill_n(a, 16, 1.f);
        alignas(64) float tHit[16];
        std::memcpy(tHit, rh.ray.tfar, sizeof tHit);
        std::fill_n(rh.ray.tfar, 16, 0.f);  // until a lane is known to have an opaque hit
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
            const glm::uvec3 tri = tris[k];
            const glm::vec3 &a = od.normals[tri.x], &b = od.normals[tri.y], &c = od.normals[tri.z];
            n0x[k] = a.x, n0y[k] = a.y, n0z[k] = a.z;
            n1x[k] = b.x, n1y[k] = b.y, n1z[k] = b.z;
            n2x[k] = c.x, n2y[k] = c.y, n2z[k] = c.z;
            glm::vec3 albedo = od.albedo;
            if (od.vertexColors) {
                const float u = rh.hit.u[k], v = rh.hit.v[k];
                albedo = srgbToLinear((1.f - u - v) * od.mesh->colors[tri.x] + u * od.mesh->colors[tri.y] +
                                      v * od.mesh->colors[tri.z]);
            }
            h.setMaterial(k, albedo, od.material);
            off[k] = od.offset;
            rh.ray.tfar[k] = tHit[k];
            h.on[k] = -1;
            ++opaqueCount;
        }
        if (opaqueCount == 0) return;

        // Smooth normals (reversed on triangles seen from behind), hit positions and the origins of
        // secondary rays.
        alignas(64) float len[16];
        for (int k = 0; k < 16; ++k) {
            const float u = rh.hit.u[k], v = rh.hit.v[k], w = 1.f - u - v;
            float x = w * n0x[k] + u * n1x[k] + v * n2x[k];
            float y = w * n0y[k] + u * n1y[k] + v * n2y[k];
            float z = w * n0z[k] + u * n1z[k] + v * n2z[k];
            const float l = std::sqrt(x * x + y * y + z * z);
            len[k] = l;
            const float d = l > 0.f ? l : 1.f;
            x /= d, y /= d, z /= d;
            // Seen from behind by the triangle's own normal, not the smooth one (see trace above).
            const float flip =
                rh.hit.Ng_x[k] * rays.dx[k] + rh.hit.Ng_y[k] * rays.dy[k] + rh.hit.Ng_z[k] * rays.dz[k] > 0.f ? -1.f
                                                                                                              : 1.f;
            x *= flip, y *= flip, z *= flip;
            detail::bendTowardsViewer(x, y, z, rays.dx[k], rays.dy[k], rays.dz[k]);
            h.nx[k] = x, h.ny[k] = y, h.nz[k] = z;
        }
        for (int k = 0; k < 16; ++k)
            if (h.on[k] && !(len[k] > 0.f)) {  // corner normals cancel: the geometric normal
                glm::vec3 g = glm::normalize(glm::vec3(rh.hit.Ng_x[k], rh.hit.Ng_y[k], rh.hit.Ng_z[k]));
                if (glm::dot(g, rays[k].dir) > 0) g = -g;
                h.nx[k] = g.x, h.ny[k] = g.y, h.nz[k] = g.z;
            }
        for (int k = 0; k < 16; ++k) {
            const float t = rh.ray.tfar[k];
            h.px[k] = rays.ox[k] + t * rays.dx[k];
            h.py[k] = rays.oy[k] + t * rays.dy[k];
            h.pz[k] = rays.oz[k] + t * rays.dz[k];
            const float lift = eps + off[k] + 1e-5f * t;
            h.qx[k] = h.px[k] + h.nx[k] * lift;
            h.qy[k] = h.py[k] + h.ny[k] * lift;
            h.qz[k] = h.pz[k] + h.nz[k] * lift;
        }
        if (o.aoSamples > 0)  // rays one by one
            for (int k = 0; k < 16; ++k)
                if (h.on[k]) {
                    const glm::vec3 q(h.qx[k], h.qy[k], h.qz[k]);
                    h.ao[k] = detail::ambientOcclusion(glm::vec3(h.nx[k], h.ny[k], h.nz[k]), o.aoSamples,
                                                       static_cast<std::uint32_t>(pix[k] * 64u + s * 16u),
                                                       [&](const glm::vec3& d) { return !occluded(q, d, aoReach); });
                }
        // Shadows: a packet towards each of the first 8 lights, single rays beyond.
        auto shadow = [&](std::size_t li, const float* lx, const float* ly, const float* lz, const float* reach,
                          int* lit) {
            if (!o.shadows) return;
            if (li >= packetLights) {
                for (int k = 0; k < 16; ++k)
                    if (lit[k] &&
                        occluded(glm::vec3(h.qx[k], h.qy[k], h.qz[k]), glm::vec3(lx[k], ly[k], lz[k]), reach[k]))
                        lit[k] = 0;
                return;
            }
            // Two native 8-wide packets (the width of AVX2 kernels): Debian's Embree 3.13, built with
            // assertions, aborted in its 8-wide occlusion kernels on our 16-wide packets
            // (`all(valid, ray.valid())`, bvh_intersector_hybrid.cpp) on a loaded machine, with every
            // active ray checked finite just before the call; it never did with 8-wide calls.
            alignas(64) RTCRay16 sr;
            RTCIntersectContext sctx;
            rtcInitIntersectContext(&sctx);
            sctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;  // a 4x4 block's rays towards one light
            for (int half = 0; half < 2; ++half) {
                alignas(32) RTCRay8 r8;
                alignas(32) int v8[8];
                bool any = false;
                for (int j = 0; j < 8; ++j) {
                    const int k = 8 * half + j;
                    r8.org_x[j] = h.qx[k], r8.org_y[j] = h.qy[k], r8.org_z[j] = h.qz[k];
                    r8.dir_x[j] = lx[k], r8.dir_y[j] = ly[k], r8.dir_z[j] = lz[k];
                    r8.tnear[j] = 0.f, r8.tfar[j] = reach[k], r8.time[j] = 0.f;
                    r8.mask[j] = 0xFFFFFFFFu, r8.flags[j] = 0u, r8.id[j] = 0u;
                    const float sum = r8.org_x[j] + r8.org_y[j] + r8.org_z[j] + r8.dir_x[j] + r8.dir_y[j] + r8.dir_z[j];
                    v8[j] = lit[k] && std::isfinite(sum) && !std::isnan(r8.tfar[j]) ? -1 : 0;
                    if (lit[k] && !v8[j]) lit[k] = 0;  // never a non-finite ray: left unlit
                    any = any || v8[j];
                }
                if (any) rtcOccluded8(v8, shadowScene, &sctx, &r8);
                for (int j = 0; j < 8; ++j) sr.tfar[8 * half + j] = v8[j] ? r8.tfar[j] : 0.f;
            }
            for (int k = 0; k < 16; ++k)
                if (sr.tfar[k] < 0.f) lit[k] = 0;
        };
        alignas(64) float cr[16], cg[16], cb[16];
        detail::shadeLanes(h, rays, lights, look.ambient, shadow, cr, cg, cb);
        for (int k = 0; k < n; ++k) {
            if (!h.on[k]) continue;
            detail::SampleResult& r = out[k];
            r.color = glm::vec3(cr[k], cg[k], cb[k]);
            r.hit = true;
            r.depth = rh.ray.tfar[k];
            r.normal = glm::vec3(h.nx[k], h.ny[k], h.nz[k]);
            r.id = float(rh.hit.geomID[k] + 1);
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
