#pragma once
/// @file A half-edge structure over a triangle mesh (the seed's §3.10), for adjacency queries: the
/// 1-ring and valence of a vertex, the faces around it, boundary loops, edge flips and splits. It is
/// built from the indexed mesh (`TriMesh` stays the exchange type) and refuses input it could not
/// represent (an edge of more than two triangles or used twice in one direction, a vertex where
/// several fans meet) with a report instead of corrupting itself.

#include <cstdint>
#include <initializer_list>
#include <vector>

#include "mesh/trimesh.h"

namespace isoforge::mesh {

class HalfEdgeMesh {
public:
    static constexpr std::uint32_t kNone = 0xFFFFFFFFu;
    struct HalfEdge {
        std::uint32_t to;    ///< vertex it points to
        std::uint32_t face;  ///< face on its left
        std::uint32_t twin;  ///< opposite half-edge, kNone on the boundary
    };

    /// @throw std::invalid_argument naming what is non-manifold or inconsistently oriented (counts and a
    ///        first example), for input the structure cannot hold.
    explicit HalfEdgeMesh(const TriMesh& mesh);

    std::size_t vertexCount() const { return positions_.size(); }
    std::size_t faceCount() const { return faces_.size(); }
    std::size_t halfEdgeCount() const { return he_.size(); }
    const HalfEdge& halfEdge(std::uint32_t h) const { return he_[h]; }
    static std::uint32_t next(std::uint32_t h) { return h - h % 3 + (h + 1) % 3; }
    static std::uint32_t prev(std::uint32_t h) { return h - h % 3 + (h + 2) % 3; }
    std::uint32_t from(std::uint32_t h) const { return he_[prev(h)].to; }

    /// Neighbour vertices of v in rotation order (for a boundary vertex, from one boundary edge to the
    /// other); empty for an isolated vertex.
    std::vector<std::uint32_t> oneRing(std::uint32_t v) const;
    std::size_t valence(std::uint32_t v) const { return oneRing(v).size(); }
    /// Faces around v in the same rotation order.
    std::vector<std::uint32_t> facesAround(std::uint32_t v) const;
    bool isBoundaryVertex(std::uint32_t v) const;
    /// Each boundary loop as its vertices in order; empty for a closed mesh.
    std::vector<std::vector<std::uint32_t>> boundaryLoops() const;

    /// Flips the interior edge of half-edge h (two triangles a-b-c, b-a-d become a-d-c, d-b-c).
    /// Returns false (and changes nothing) on a boundary edge or when edge c-d already exists.
    /// Local: O(valence of c) for the check, O(1) for the change (faces keep their indices).
    bool flip(std::uint32_t h);
    /// Splits the edge of h at its midpoint: the triangles on either side become two each (the new
    /// ones are appended). Returns the new vertex. Local: O(1).
    std::uint32_t split(std::uint32_t h);

    TriMesh toTriMesh() const;

private:
    void build();
    void setFace(std::uint32_t f, const glm::uvec3& t);  ///< the face and its three half-edges, unlinked
    void link(std::uint32_t h, std::uint32_t t);         ///< makes h and t twins (t may be kNone)
    /// Re-chooses the outgoing half-edge of vertices whose one was in the changed faces.
    void refreshOutgoing(std::initializer_list<std::uint32_t> vertices, std::initializer_list<std::uint32_t> faces);
    /// An outgoing half-edge of v, the boundary one where there is one; kNone if v is isolated.
    std::uint32_t outgoing(std::uint32_t v) const { return out_[v]; }
    std::vector<glm::vec3> positions_;
    std::vector<glm::uvec3> faces_;
    std::vector<HalfEdge> he_;
    std::vector<std::uint32_t> out_;
};

}  // namespace isoforge::mesh
