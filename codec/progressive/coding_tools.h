// The coding tools of a stream: the bits of the stream header's `tools`
// field (docs/spec/progressive-format.md, section 3). The encoder uses all of them
// that its version defines (kToolTexcoordPrediction only in streams with
// texture coordinates or colours); each can be turned off
// (StreamWriteOptions::tools) to measure what it saves (docs/design/codec.md). A
// version 1 stream has no tools; version 2 defines bits 0-5 (one byte in its
// header), version 3 bits 0-8 (two bytes).
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_CODING_TOOLS_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_CODING_TOOLS_H_

#include <cstdint>
#include <string>
#include <vector>

namespace meshstream {

// A set of StreamTool bits.
using ToolSet = uint16_t;

enum StreamTool : ToolSet {
  kToolGeometryPrediction = 1,  // split vectors predicted from the ring, residual coded
  kToolLocalFrame = 2,          // residual components ordered (tangential, tangential, normal)
  kToolWingRank = 4,            // cut edges coded as a rank in an order the ring's geometry predicts
  kToolAttributePrediction = 8, // normals predicted from the decoded geometry
  kToolTexcoordPrediction = 16, // texture coordinates and colours predicted by the ring's map (texcoord_prediction.h)
  kToolSeams = 32,              // seam edges collapsed on both sides together (seam_twins.h); header lists base twins
  kToolSplitContexts = 64,      // version 3: split bits in contexts of the reliable graph (split_bit_contexts.h)
  kToolModelModes = 128,        // version 3: per slot a static table or a model adapted within each datagram (slot_model.h)
  kToolRingPredictor = 256,     // version 3: split vectors predicted in the frame from the ring and 2-ring (ring_predictor.h)
  kToolCutCrossings = 512,      // version 4: the cut's rank in the order of the ring's crossings (cut_crossings.h; with bit 2)
};
constexpr ToolSet kVersion2Tools = kToolGeometryPrediction | kToolLocalFrame | kToolWingRank |
                                   kToolAttributePrediction | kToolTexcoordPrediction | kToolSeams;
constexpr ToolSet kVersion3Tools = kVersion2Tools | kToolSplitContexts | kToolModelModes | kToolRingPredictor;
constexpr ToolSet kVersion4Tools = kVersion3Tools | kToolCutCrossings;
// Every tool some version defines.
constexpr ToolSet kEveryTool = kVersion4Tools;
// What an encoder uses when told nothing (the measured defaults, docs/design/codec.md).
constexpr ToolSet kAllTools = kVersion3Tools;

// The tools a stream of `version` may carry (0 for version 1, and for an
// unknown version).
constexpr ToolSet DefinedTools(uint8_t version) {
  return version == 2 ? kVersion2Tools : version == 3 ? kVersion3Tools : version == 4 ? kVersion4Tools : ToolSet{0};
}

// The tools' names, as the CLI's --tools and the --json reports spell them,
// in bit order.
struct ToolName {
  StreamTool tool;
  const char* name;
};
constexpr ToolName kToolNames[] = {
    {kToolGeometryPrediction, "geometry"}, {kToolLocalFrame, "frame"},         {kToolWingRank, "rank"},
    {kToolAttributePrediction, "normals"}, {kToolTexcoordPrediction, "texcoords"}, {kToolSeams, "seams"},
    {kToolSplitContexts, "splitbits"},     {kToolModelModes, "models"},         {kToolRingPredictor, "predictor"},
    {kToolCutCrossings, "crossings"},
};

// The names of the tools set in `tools`, in bit order.
inline std::vector<std::string> ToolNamesOf(ToolSet tools) {
  std::vector<std::string> out;
  for (const ToolName& t : kToolNames)
    if (tools & t.tool) out.push_back(t.name);
  return out;
}

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_CODING_TOOLS_H_
