// The one way this project includes OpenVDB's core.
//
// It declares the grid and tree classes we use as explicit instantiations that live in exactly one
// translation unit (vdbmap/src/openvdb_instantiate.cpp), so no other translation unit instantiates
// a whole tree again: this cuts compile time about 2.5x (see ../shared/BUILD_NOTES.md).
// Include openvdb/tools/*.h only in the translation unit that uses the tool, never here.
#pragma once

#include <openvdb/openvdb.h>

namespace openvdb {
OPENVDB_USE_VERSION_NAMESPACE
namespace OPENVDB_VERSION_NAME {
extern template class tree::Tree<FloatTree::RootNodeType>;
extern template class Grid<FloatTree>;
extern template class tree::Tree<Int32Tree::RootNodeType>;
extern template class Grid<Int32Tree>;
extern template class tree::Tree<Int64Tree::RootNodeType>;
extern template class Grid<Int64Tree>;
extern template class tree::Tree<BoolTree::RootNodeType>;
extern template class Grid<BoolTree>;
extern template class tree::Tree<MaskTree::RootNodeType>;
extern template class Grid<MaskTree>;
}  // namespace OPENVDB_VERSION_NAME
}  // namespace openvdb

namespace vdbmap {
/// Registers OpenVDB's grid types once per process; safe to call from any thread, any number of
/// times. Every entry point that creates, reads or writes grids calls it.
void initializeOpenVdb();
}  // namespace vdbmap
