// Fewer triangles for display: vertex clustering on a regular grid (Rossignac-Borrel). Every
// vertex moves to the mean of the vertices in its cell; triangles whose corners fall in fewer
// than three cells vanish. Shape error is at most one cell diagonal; topology may change.
#pragma once

#include "vdbmap/triangle_mesh.hpp"

#include <cstddef>

namespace vdbmap::report {

/// The mesh with its vertices clustered in cubes of edge `cell_m` (> 0, finite; throws
/// std::invalid_argument otherwise). Triangles keep their orientation; unused vertices are dropped.
TriangleMesh clusterVertices(const TriangleMesh& mesh, double cell_m);

/// `mesh` itself when it has at most `max_triangles` (>= 1), else clusterVertices with the
/// smallest cell of start_cell_m x 2^k (k >= 0) that leaves at most max_triangles.
TriangleMesh decimateToBudget(const TriangleMesh& mesh, std::size_t max_triangles, double start_cell_m);

}  // namespace vdbmap::report
