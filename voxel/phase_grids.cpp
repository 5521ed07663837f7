#include "voxel/phase_grids.h"

#include <openvdb/io/File.h>
#include <openvdb/tools/Prune.h>
#include <tbb/parallel_for.h>

#include <array>
#include <cstring>
#include <memory>
#include <mutex>
#include <vector>

#include "mesorock/errors.h"
#include "voxel/segment.h"

namespace mesorock::voxel {
namespace {

using MaskLeaf = openvdb::MaskTree::LeafNodeType;
using UInt8Leaf = UInt8Tree::LeafNodeType;
using Int32Leaf = openvdb::Int32Tree::LeafNodeType;
constexpr int kBlock = 8;  // OpenVDB leaf edge (Log2Dim 3)
constexpr int kBlockVoxels = kBlock * kBlock * kBlock;
static_assert(MaskLeaf::DIM == kBlock && UInt8Leaf::DIM == kBlock && Int32Leaf::DIM == kBlock,
              "leaf size");

// Everything one z-slab of 8x8x8 blocks contributes, gathered in parallel, added to the trees in
// one serial pass (adding a leaf is a pointer insertion). Label leaves are made either 8-bit or
// 32-bit, never both.
struct SlabNodes {
  std::array<std::vector<std::unique_ptr<MaskLeaf>>, kPhaseCount> mask_leaves;
  std::array<std::vector<openvdb::Coord>, kPhaseCount> mask_tiles;
  std::vector<std::unique_ptr<UInt8Leaf>> uint8_leaves;
  std::vector<std::unique_ptr<Int32Leaf>> int32_leaves;
  std::vector<std::pair<openvdb::Coord, int>> label_tiles;
  std::array<bool, kPhaseCount> present{};
};

// A label leaf with the block's codes (leaf offset order) and the active mask of its phase voxels.
template <class Leaf>
std::unique_ptr<Leaf> label_leaf(const openvdb::Coord& origin, const std::uint8_t* block,
                                 const std::uint64_t (*words)[kBlock]) {
  using Value = typename Leaf::ValueType;
  auto leaf = std::make_unique<Leaf>(origin, Value(0), false);
  Value* values = leaf->buffer().data();
  for (int i = 0; i < kBlockVoxels; ++i) values[i] = static_cast<Value>(block[i]);
  auto& mask = leaf->getValueMask();
  for (int w = 0; w < kBlock; ++w) {
    mask.template getWord<openvdb::Index64>(static_cast<openvdb::Index>(w)) =
        words[1][w] | words[2][w] | words[3][w] | words[4][w];
  }
  return leaf;
}

// Adds the slabs' label leaves and tiles to a new grid named "labels".
template <class GridT>
openvdb::GridBase::Ptr assemble_label_grid(std::vector<SlabNodes>& slabs) {
  using Value = typename GridT::ValueType;
  typename GridT::Ptr grid = GridT::create(Value(0));
  auto& tree = grid->tree();
  for (SlabNodes& slab : slabs) {
    if constexpr (std::is_same_v<Value, std::uint8_t>) {
      for (auto& leaf : slab.uint8_leaves) tree.addLeaf(leaf.release());
      slab.uint8_leaves.clear();
    } else {
      for (auto& leaf : slab.int32_leaves) tree.addLeaf(leaf.release());
      slab.int32_leaves.clear();
    }
    for (const auto& [c, phase] : slab.label_tiles) {
      tree.addTile(1, c, static_cast<Value>(phase), true);
    }
    slab.label_tiles.clear();
    slab.label_tiles.shrink_to_fit();
  }
  openvdb::tools::prune(tree);
  return grid;
}

}  // namespace

void initialize_openvdb() {
  static std::once_flag once;
  std::call_once(once, [] {
    openvdb::initialize();
    if (!UInt8Grid::isRegistered()) UInt8Grid::registerGrid();
  });
}

const char* label_grid_type_name(LabelGridType type) {
  switch (type) {
    case LabelGridType::kNone:
      return "none";
    case LabelGridType::kUInt8:
      return "uint8";
    case LabelGridType::kInt32:
      return "int32";
  }
  return "?";
}

LabelGridType parse_label_grid_type(const std::string& name) {
  if (name == "none") return LabelGridType::kNone;
  if (name == "uint8") return LabelGridType::kUInt8;
  if (name == "int32") return LabelGridType::kInt32;
  throw ConfigError("unknown label grid type '" + name + "' (expected uint8, int32 or none)");
}

openvdb::math::Transform::Ptr voxel_transform(const Spacing& spacing) {
  openvdb::math::Mat4d scale = openvdb::math::Mat4d::identity();
  scale.preScale(openvdb::math::Vec3d(spacing.dx, spacing.dy, spacing.dz));
  return openvdb::math::Transform::createLinearTransform(scale);
}

openvdb::GridPtrVec build_phase_grids(const Volume& labels, const PhaseGridOptions& options) {
  initialize_openvdb();
  if (labels.dtype() != DType::kUInt8) throw ConfigError("phase grids need a uint8 label volume");
  const Shape s = labels.shape();
  const std::uint8_t* codes = labels.data<std::uint8_t>();
  const std::int64_t bz = (s.nz + kBlock - 1) / kBlock, by = (s.ny + kBlock - 1) / kBlock,
                     bx = (s.nx + kBlock - 1) / kBlock;
  std::vector<SlabNodes> slabs(static_cast<std::size_t>(bz));
  std::vector<std::string> errors(static_cast<std::size_t>(bz));

  tbb::parallel_for(std::int64_t(0), bz, [&](std::int64_t kb) {
    SlabNodes& slab = slabs[static_cast<std::size_t>(kb)];
    // Per block: the phase codes in leaf offset order (x slowest, z fastest, as OpenVDB stores
    // them), and per phase the 8 64-bit words of its bit mask (word x, bit y * 8 + z), so leaves
    // are filled word by word rather than voxel by voxel.
    std::uint8_t block[kBlockVoxels];
    std::uint64_t words[kPhaseCount][kBlock];
    for (std::int64_t jb = 0; jb < by; ++jb) {
      for (std::int64_t ib = 0; ib < bx; ++ib) {
        const std::int64_t x0 = ib * kBlock, y0 = jb * kBlock, z0 = kb * kBlock;
        const std::int64_t ex = std::min<std::int64_t>(kBlock, s.nx - x0),
                           ey = std::min<std::int64_t>(kBlock, s.ny - y0),
                           ez = std::min<std::int64_t>(kBlock, s.nz - z0);
        std::fill(std::begin(block), std::end(block), 0);
        std::memset(words, 0, sizeof words);
        unsigned present = 0;
        for (std::int64_t dz = 0; dz < ez; ++dz) {
          for (std::int64_t dy = 0; dy < ey; ++dy) {
            const std::uint8_t* row = codes + ((z0 + dz) * s.ny + (y0 + dy)) * s.nx + x0;
            const unsigned bit = static_cast<unsigned>((dy << 3) | dz);
            for (std::int64_t dx = 0; dx < ex; ++dx) {
              const unsigned c = row[dx];
              if (c >= kPhaseCount) {
                errors[static_cast<std::size_t>(kb)] =
                    "label volume holds value " + std::to_string(c) + ", not a phase code";
                return;
              }
              block[(dx << 6) | bit] = static_cast<std::uint8_t>(c);
              words[c][dx] |= std::uint64_t(1) << bit;
              present |= 1u << c;
            }
          }
        }
        const bool full = ex == kBlock && ey == kBlock && ez == kBlock;
        const openvdb::Coord origin(static_cast<int>(x0), static_cast<int>(y0),
                                    static_cast<int>(z0));
        if (full && (present & (present - 1)) == 0 && !(present & 1u)) {
          // One phase fills the whole block: a tile in each grid, no leaf.
          int phase = 0;
          while (!(present & (1u << phase))) ++phase;
          slab.mask_tiles[static_cast<std::size_t>(phase)].push_back(origin);
          slab.label_tiles.emplace_back(origin, phase);
          slab.present[static_cast<std::size_t>(phase)] = true;
          continue;
        }
        if ((present & ~1u) == 0) continue;  // only outside voxels: nothing to store
        if (options.label_grid == LabelGridType::kUInt8) {
          slab.uint8_leaves.push_back(label_leaf<UInt8Leaf>(origin, block, words));
        } else if (options.label_grid == LabelGridType::kInt32) {
          slab.int32_leaves.push_back(label_leaf<Int32Leaf>(origin, block, words));
        }
        for (int phase = 1; phase < kPhaseCount; ++phase) {
          if (!(present & (1u << phase))) continue;
          slab.present[static_cast<std::size_t>(phase)] = true;
          if (!options.phase_masks) continue;
          auto leaf = std::make_unique<MaskLeaf>(origin, false, false);
          auto& mask = leaf->getValueMask();
          for (int w = 0; w < kBlock; ++w) {
            mask.template getWord<openvdb::Index64>(static_cast<openvdb::Index>(w)) =
                words[phase][w];
          }
          slab.mask_leaves[static_cast<std::size_t>(phase)].push_back(std::move(leaf));
        }
      }
    }
  });
  for (const std::string& e : errors) {
    if (!e.empty()) throw ConfigError(e);
  }

  const openvdb::math::Transform::Ptr transform = voxel_transform(labels.spacing());
  openvdb::GridPtrVec grids;
  if (options.phase_masks) {
    for (int phase = 1; phase < kPhaseCount; ++phase) {
      const auto p = static_cast<std::size_t>(phase);
      bool any = false;
      for (const SlabNodes& slab : slabs) any = any || slab.present[p];
      if (!any) continue;
      openvdb::MaskGrid::Ptr grid = openvdb::MaskGrid::create();
      openvdb::MaskTree& tree = grid->tree();
      for (SlabNodes& slab : slabs) {
        for (auto& leaf : slab.mask_leaves[p]) tree.addLeaf(leaf.release());
        for (const openvdb::Coord& c : slab.mask_tiles[p]) tree.addTile(1, c, true, true);
        slab.mask_leaves[p].clear();
        slab.mask_tiles[p].clear();
      }
      openvdb::tools::prune(tree);
      grid->setName(phase_name(static_cast<Phase>(phase)));
      grid->setTransform(transform->copy());
      grid->insertMeta("phase", openvdb::StringMetadata(phase_name(static_cast<Phase>(phase))));
      grid->insertMeta("phase_code", openvdb::Int32Metadata(phase));
      grid->insertMeta("unit", openvdb::StringMetadata(labels.spacing().unit));
      grids.push_back(grid);
    }
  }
  if (options.label_grid != LabelGridType::kNone) {
    openvdb::GridBase::Ptr grid = options.label_grid == LabelGridType::kUInt8
                                      ? assemble_label_grid<UInt8Grid>(slabs)
                                      : assemble_label_grid<openvdb::Int32Grid>(slabs);
    grid->setName("labels");
    grid->setTransform(transform->copy());
    grid->insertMeta("phase_codes", openvdb::StringMetadata(
                                        "0=outside,1=pore,2=organic,3=inorganic,4=organic_pore"));
    grid->insertMeta("unit", openvdb::StringMetadata(labels.spacing().unit));
    grids.push_back(grid);
  }
  return grids;
}

void write_vdb(const std::filesystem::path& path, const openvdb::GridPtrVec& grids,
               const std::map<std::string, std::string>& metadata,
               const std::string& display_name) {
  initialize_openvdb();
  try {
    openvdb::io::File file(path.string());
    file.setCompression(openvdb::io::Archive::hasBloscCompression()
                            ? (openvdb::io::COMPRESS_BLOSC | openvdb::io::COMPRESS_ACTIVE_MASK)
                            : (openvdb::io::COMPRESS_ZIP | openvdb::io::COMPRESS_ACTIVE_MASK));
    openvdb::MetaMap file_metadata;
    for (const auto& [key, value] : metadata) {
      file_metadata.insertMeta(key, openvdb::StringMetadata(value));
    }
    file.write(grids, file_metadata);
    file.close();
  } catch (const openvdb::Exception& e) {
    throw IoError(display_name + ": cannot write VDB (" + e.what() + ")");
  }
}

}  // namespace mesorock::voxel
