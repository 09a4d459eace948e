#pragma once
/// @file Polygonal primitives with a resolution (the seed's §3.9, written to be closed, watertight and
/// outward-oriented): each is an indexed triangle mesh whose vertices are shared between faces.

#include <string>
#include <vector>

#include "mesh/trimesh.h"

namespace isoforge::mesh {

/// Unit cube [-0.5, 0.5]^3, each face an n x n grid (n >= 1).
TriMesh makeCube(int n = 1);
/// Cylinder of radius r and height h along z, centred; n >= 3 sides, closed by two caps.
TriMesh makeCylinder(int n, float r = 0.5f, float h = 1.f);
/// Cone of base radius r and height h along z (base at -h/2, apex at +h/2); n >= 3 sides, closed base.
TriMesh makeCone(int n, float r = 0.5f, float h = 1.f);
/// UV sphere of radius r: n >= 3 segments around z, n/2 (>= 2) rings, a single vertex at each pole.
TriMesh makeUvSphere(int n, float r = 0.5f);
/// Icosahedron subdivided `levels` times (each level splits every triangle in four), on radius r.
TriMesh makeIcosphere(int levels, float r = 0.5f);
/// Torus around z: n >= 3 segments around the axis, max(3, n/2) around the tube; radii R > r > 0.
TriMesh makeTorus(int n, float R = 0.5f, float r = 0.2f);

/// By name: cube, cylinder, cone, sphere (UV), icosphere (resolution = subdivision levels), torus.
/// @throw std::invalid_argument for an unknown name or a resolution out of range (1..4096; icosphere 0..8).
TriMesh makePrimitive(const std::string& name, int resolution);
/// The names makePrimitive knows.
std::vector<std::string> primitiveNames();

}  // namespace isoforge::mesh
