// The explicit instantiations that openvdb.hpp declares extern (see that header for why).
#include "vdbmap/openvdb.hpp"

#include <mutex>

namespace openvdb {
OPENVDB_USE_VERSION_NAMESPACE
namespace OPENVDB_VERSION_NAME {
template class tree::Tree<FloatTree::RootNodeType>;
template class Grid<FloatTree>;
template class tree::Tree<Int32Tree::RootNodeType>;
template class Grid<Int32Tree>;
template class tree::Tree<Int64Tree::RootNodeType>;
template class Grid<Int64Tree>;
template class tree::Tree<BoolTree::RootNodeType>;
template class Grid<BoolTree>;
template class tree::Tree<MaskTree::RootNodeType>;
template class Grid<MaskTree>;
}  // namespace OPENVDB_VERSION_NAME
}  // namespace openvdb

namespace vdbmap {
void initializeOpenVdb() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}
}  // namespace vdbmap
