#pragma once
/// @file SegmentationMetadata.h
/// 3D Slicer's segmentations (.seg.nrrd): the segments its key/value pairs declare
/// (Segment{N}_ID, _Name, _Color, _LabelValue, _Layer) and the labels they give a volume
/// (internal to io/; readNrrd uses it for every NRRD file).
///
/// A segment is the voxels that hold its LabelValue in its Layer. A 3-D file has one layer; a
/// 4-D file stores its layers along the first axis, so that segments may overlap. Where a
/// voxel is non-zero in several layers, the segment that comes later in the file's numbering
/// (the larger N) holds it; values no segment declares rank below every declared segment, in
/// order of (layer, value). Segments left with no voxel are dropped (a warning names them).
///
/// Pure functions of their arguments: thread-safe.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "voxcut/voxel/LabelVolume.h"

namespace voxcut::volumeio {

/// One segment of a segmentation, as its key/value pairs declare it.
struct Segment {
  int number = 0;                              ///< N of the Segment{N}_ keys: the file's order
  std::string id;                              ///< Segment{N}_ID
  std::string name;                            ///< Segment{N}_Name (control bytes as '?')
  std::optional<std::array<float, 3>> colour;  ///< Segment{N}_Color, RGB in [0, 1]
  std::int64_t labelValue = 1;                 ///< Segment{N}_LabelValue (1 when absent)
  int layer = 0;  ///< Segment{N}_Layer (absent: N when the file has layers, else 0)
};

/// The NRRD key/value pairs (key, value) of a header, in file order.
using KeyValues = std::vector<std::pair<std::string, std::string>>;

/// The segments `keyValues` declare, sorted by number; `layers` is the number of layers the
/// data hold (1 for 3-D data). Throws InputError naming `what` for a LabelValue or Layer that
/// is not an integer; a colour that is not three numbers in [0, 1], and a segment whose layer
/// is not in the data, are dropped with a line in `warnings`.
[[nodiscard]] std::vector<Segment> parseSegments(const KeyValues& keyValues, int layers,
                                                 const std::string& what,
                                                 std::vector<std::string>& warnings);

/// Names and colours the labels of the one-layer `volume` (labels as setLabelsFromSamples
/// made them) from `segments`: label value v takes the first segment of layer 0 whose
/// LabelValue is v. Segments with no voxel are dropped with a warning.
void nameLabels(LabelVolume& volume, const std::vector<Segment>& segments);

/// Builds the compact labels of `volume` (dims set) from layered samples: `layers` samples of
/// `type` per voxel at `data`, the layer index varying fastest, in the byte order `bigEndian`.
/// Each voxel takes the segment that ranks highest among its non-zero layers (see the file
/// comment). A label's value is its segment's LabelValue when no other label of the volume
/// has it, else one above every value in use; names and colours come from the segments.
/// Throws InputError naming `what` as setLabelsFromSamples does, and for more than 65,535
/// distinct (layer, value) pairs. Time and memory linear in the samples.
void setLabelsFromLayers(LabelVolume& volume, const void* data, int layers, SampleType type,
                         bool bigEndian, const std::vector<Segment>& segments,
                         const std::string& what);

}  // namespace voxcut::volumeio
