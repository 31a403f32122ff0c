// The coding tools of a version 2 stream: the bits of the stream header's
// `tools` byte (docs/progressive-format.md, section 3). The encoder uses all
// of them (kToolTexcoordPrediction only in streams with texture coordinates
// or colours); each can be turned off (StreamWriteOptions::tools) to measure
// what it saves (docs/codec.md). A version 1 stream has no tools.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_CODING_TOOLS_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_CODING_TOOLS_H_

#include <cstdint>
#include <string>
#include <vector>

namespace meshstream {

enum StreamTool : uint8_t {
  kToolGeometryPrediction = 1,  // split vectors predicted from the ring, residual coded
  kToolLocalFrame = 2,          // residual components ordered (tangential, tangential, normal)
  kToolWingRank = 4,            // cut edges coded as a rank in an order the ring's geometry predicts
  kToolAttributePrediction = 8, // normals predicted from the decoded geometry
  kToolTexcoordPrediction = 16, // texture coordinates and colours predicted by the ring's map (texcoord_prediction.h)
  kToolSeams = 32,              // seam edges collapsed on both sides together (seam_twins.h); header lists base twins
};
constexpr uint8_t kAllTools = kToolGeometryPrediction | kToolLocalFrame | kToolWingRank | kToolAttributePrediction |
                              kToolTexcoordPrediction | kToolSeams;
constexpr uint8_t kDefinedTools = kAllTools;

// The tools' names, as the CLI's --tools and the --json reports spell them,
// in bit order.
struct ToolName {
  StreamTool tool;
  const char* name;
};
constexpr ToolName kToolNames[] = {
    {kToolGeometryPrediction, "geometry"}, {kToolLocalFrame, "frame"},         {kToolWingRank, "rank"},
    {kToolAttributePrediction, "normals"}, {kToolTexcoordPrediction, "texcoords"}, {kToolSeams, "seams"},
};

// The names of the tools set in `tools`, in bit order.
inline std::vector<std::string> ToolNamesOf(uint8_t tools) {
  std::vector<std::string> out;
  for (const ToolName& t : kToolNames)
    if (tools & t.tool) out.push_back(t.name);
  return out;
}

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_CODING_TOOLS_H_
