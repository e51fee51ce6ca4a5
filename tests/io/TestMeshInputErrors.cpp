// Malformed mesh files: each is rejected promptly with one InputError line that names the file,
// the line (text) or byte offset (binary), and what is wrong. None may hang, crash or allocate
// from a declared count.

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "CubeFiles.h"
#include "TempDir.h"
#include "voxcut/core/Error.h"
#include "voxcut/io/MeshReader.h"

namespace voxcut {
namespace {

using test::appendEndian;
using test::appendRaw;
using test::TempDir;

struct BadFile {
  std::string name;                ///< file name; its extension picks the reader
  std::string bytes;               ///< content
  std::vector<std::string> parts;  ///< what the message must contain besides the path
};

const std::string kPlyXyz = "property float x\nproperty float y\nproperty float z\n";
const std::string kPlyFace = "property list uchar int vertex_indices\n";

std::string asciiPly(const std::string& elements, const std::string& body) {
  return "ply\nformat ascii 1.0\n" + elements + "end_header\n" + body;
}

/// Binary little-endian PLY with 3 float vertices and the given face header and bytes.
std::string binaryPly(const std::string& faceHeader, const std::string& faceBytes) {
  std::string s = "ply\nformat binary_little_endian 1.0\nelement vertex 3\n" + kPlyXyz +
                  faceHeader + "end_header\n";
  for (const float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) appendRaw(s, v);
  return s + faceBytes;
}

std::string bytesOf(std::initializer_list<int> values) {
  std::string s;
  for (const int v : values) s.push_back(static_cast<char>(v));
  return s;
}

/// A binary STL: `header` padded to 80 bytes, `declared` as the count, then `facets` facets of
/// the unit triangle; `nanAt` >= 0 puts a NaN in that float of the first facet.
std::string binaryStl(std::uint32_t declared, int facets, int nanAt = -1) {
  std::string s(80, ' ');
  appendRaw(s, declared);
  for (int f = 0; f < facets; ++f) {
    const float values[12] = {0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0};
    for (int k = 0; k < 12; ++k) appendRaw(s, f == 0 && k == nanAt ? std::nanf("") : values[k]);
    appendRaw(s, std::uint16_t{0});
  }
  return s;
}

const std::string kTri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
const std::string kOffHead = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n";

std::vector<BadFile> badFiles() {
  std::string bigEndianNan = test::cubeRichBinaryPly(true);
  bigEndianNan.replace(bigEndianNan.find("end_header\n") + 11 + 4, 8,
                       std::string("\x7f\xf8\0\0\0\0\0\0", 8));
  std::string truncatedBigEndian = test::cubeRichBinaryPly(true);
  truncatedBigEndian.resize(truncatedBigEndian.size() - 3);
  return {
      // OBJ
      {"twoCorners.obj", kTri + "f 1 2\n", {"line 4", "2 corners", "at least 3"}},
      {"indexZero.obj", kTri + "f 0 1 2\n", {"line 4", "index 0"}},
      {"indexHigh.obj", kTri + "f 1 2 4\n", {"line 4", "vertex index 4 out of range"}},
      {"forwardIndex.obj", "v 0 0 0\nf 1 2 3\nv 1 0 0\nv 0 1 0\n", {"line 2", "out of range"}},
      {"negativeTooFar.obj", kTri + "f -1 -2 -4\n", {"line 4", "-4 out of range"}},
      {"shortVertex.obj", "v 0 0\n", {"line 1", "x y z needed"}},
      {"badNumber.obj", "v 0 0 0\nv 1 zero 0\n", {"line 2", "'zero' is not a number"}},
      {"overflow.obj", "v 1e999 0 0\n", {"line 1", "non-finite"}},
      {"nanW.obj", "v 0 0 0 abc\n", {"line 1", "'abc' is not a number"}},
      {"slashes.obj", kTri + "f 1/1/1/1 2 3\n", {"line 4", "1/1/1/1"}},
      {"badTexture.obj", kTri + "f 1/x 2 3\n", {"line 4", "1/x"}},
      {"emptyTexture.obj", kTri + "f 1/ 2/ 3/\n", {"line 4", "is not i, i/t"}},
      {"hugeIndex.obj", kTri + "f 1 2 99999999999999999999999\n", {"line 4", "no vertex index"}},
      {"nulByte.obj", kTri + std::string("f 1 2\0 3\n", 9), {"line 4", "NUL"}},
      // STL
      {"countTooHigh.stl", binaryStl(1000, 2), {"byte 80", "declares 1000 triangles"}},
      {"countTooLow.stl", binaryStl(1, 2), {"byte 80", "declares 1 triangles"}},
      {"absurdCount.stl", binaryStl(0xffffffffu, 0), {"byte 80", "declares 4294967295"}},
      {"nan.stl", binaryStl(1, 1, 7), {"byte 112", "non-finite", "triangle 0"}},
      {"shortBinary.stl", "abc", {"byte 3", "84-byte"}},
      {"noEndsolid.stl",
       "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
       "vertex 0 1 0\nendloop\nendfacet\n",
       {"line 8", "without 'endsolid'"}},
      {"twoVertices.stl",
       "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
       "endloop\nendfacet\nendsolid\n",
       {"line 6", "facet has 2 vertices"}},
      {"fourVertices.stl",
       "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
       "vertex 0 1 0\nvertex 1 1 0\n",
       {"line 7", "more than 3"}},
      {"asciiNan.stl",
       "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 nan 0\n",
       {"line 4", "non-finite"}},
      {"asciiJunk.stl",
       "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nbanana\n",
       {"line 5", "expected 'vertex x y z'"}},
      // PLY
      {"noEndHeader.ply", "ply\nformat ascii 1.0\n", {"line 2", "no end_header"}},
      {"noMagic.ply", "plx\nformat ascii 1.0\nend_header\n", {"line 1", "not a PLY file"}},
      {"badFormat.ply",
       "ply\nformat binary_middle_endian 1.0\nend_header\n",
       {"line 2", "binary_middle_endian"}},
      {"badType.ply",
       asciiPly("element vertex 1\nproperty float128 x\n", "0\n"),
       {"line 4", "float128"}},
      {"noZ.ply",
       asciiPly("element vertex 1\nproperty float x\nproperty float y\n", "0 0\n"),
       {"line 3", "x, y, z"}},
      {"floatIndices.ply",
       asciiPly("element vertex 3\n" + kPlyXyz +
                    "element face 1\n"
                    "property list uchar float vertex_indices\n",
                ""),
       {"line 8", "integer type"}},
      {"twoVertexElements.ply",
       asciiPly("element vertex 1\n" + kPlyXyz + "element vertex 1\n" + kPlyXyz, ""),
       {"line 7", "a second 'vertex' element"}},
      {"unknownHeaderLine.ply",
       "ply\nformat ascii 1.0\nbanana split\nend_header\n",
       {"line 3", "unknown header line"}},
      {"zeroIndexFace.ply",
       asciiPly("element vertex 3\n" + kPlyXyz + "element face 1\n" + kPlyFace,
                "0 0 0\n1 0 0\n0 1 0\n0\n"),
       {"line 13", "face has 0 vertex indices"}},
      {"fewerFaces.ply",
       asciiPly("element vertex 3\n" + kPlyXyz + "element face 2\n" + kPlyFace,
                "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
       {"line 13", "after 1 of 2 'face' elements"}},
      {"moreFaces.ply",
       asciiPly("element vertex 3\n" + kPlyXyz + "element face 1\n" + kPlyFace,
                "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n"),
       {"line 14", "beyond the elements"}},
      {"shortList.ply",
       asciiPly("element vertex 3\n" + kPlyXyz + "element face 1\n" + kPlyFace,
                "0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n"),
       {"line 13", "list declares 4 values"}},
      {"extraValue.ply",
       asciiPly("element vertex 3\n" + kPlyXyz, "0 0 0\n1 0 0 5\n0 1 0\n"),
       {"line 9", "more than declared"}},
      {"asciiIndexHigh.ply",
       asciiPly("element vertex 3\n" + kPlyXyz + "element face 1\n" + kPlyFace,
                "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"),
       {"line 13", "vertex index 3 out of range"}},
      {"asciiNegativeIndex.ply",
       asciiPly("element vertex 3\n" + kPlyXyz + "element face 1\n" + kPlyFace,
                "0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n"),
       {"line 13", "vertex index -1 out of range"}},
      {"asciiInf.ply",
       asciiPly("element vertex 1\n" + kPlyXyz, "0 inf 0\n"),
       {"line 8", "non-finite"}},
      {"absurdAsciiCount.ply",
       asciiPly("element vertex 3\n" + kPlyXyz +
                    "element junk 1000000000000000000\n"
                    "property uchar a\n",
                "0 0 0\n"),
       {"line 9", "1000000000000000003 lines"}},
      {"tooManyVertices.ply",
       asciiPly("element vertex 4000000000\n" + kPlyXyz, ""),
       {"line 3", "too many vertices"}},
      {"negativeCount.ply",
       asciiPly("element vertex -3\n" + kPlyXyz, ""),
       {"line 3", "is not a count"}},
      {"binaryZeroIndexFace.ply",
       binaryPly("element face 1\n" + kPlyFace, bytesOf({0})),
       {"byte 205", "face has 0 vertex indices"}},
      {"binaryTruncated.ply",
       test::cubeBinaryPly().substr(0, 400),
       {"byte 396", "runs past the end", "'face' element 10 of 12"}},
      {"binaryTruncatedVertices.ply",
       test::cubeBinaryPly().substr(0, 200),
       {"byte 170", "'vertex' declares 8 items"}},
      {"binaryTruncatedBigEndian.ply", truncatedBigEndian, {"byte ", "data ends inside 'edge'"}},
      {"binaryNanBigEndian.ply", bigEndianNan, {"byte ", "non-finite", "'vertex' element 0"}},
      {"binaryTrailing.ply", test::cubeBinaryPly() + "xy", {"byte 422", "2 bytes beyond"}},
      {"binaryIndexHigh.ply",
       binaryPly("element face 1\n" + kPlyFace, bytesOf({3, 0, 0, 0, 0, 1, 0, 0, 0, 9, 0, 0, 0})),
       {"byte 214", "vertex index 9 out of range"}},
      {"binaryNegativeCount.ply",
       binaryPly("element face 1\nproperty list char int vertex_indices\n", bytesOf({255})),
       {"byte 204", "negative list count -1"}},
      {"binaryHugeList.ply",
       binaryPly("element face 1\nproperty list uint int vertex_indices\n",
                 bytesOf({255, 255, 255, 255})),
       {"byte 204", "list of 4294967295 values"}},
      {"binaryAbsurdCount.ply",
       binaryPly("element face 99999999999\n" + kPlyFace, bytesOf({3, 0, 0, 0})),
       {"byte 179", "'face' declares 99999999999 items"}},
      // OFF
      {"fewerVertices.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n", {"line 4", "after 2 of 3 vertices"}},
      {"fewerFaces.off",
       "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
       {"line 6", "after 1 of 2 faces"}},
      {"moreFaces.off", kOffHead + "3 0 1 2\n3 0 1 2\n", {"line 7", "data beyond"}},
      {"twoIndexFace.off", kOffHead + "2 0 1\n", {"line 6", "2 vertex indices"}},
      {"zeroIndexFace.off", kOffHead + "0\n", {"line 6", "0 vertex indices"}},
      {"shortFace.off", kOffHead + "5 0 1 2\n", {"line 6", "declares 5 vertex indices"}},
      {"offIndexHigh.off", kOffHead + "3 0 1 3\n", {"line 6", "vertex index 3 out of range"}},
      {"offNegative.off", kOffHead + "3 0 -1 2\n", {"line 6", "vertex index -1 out of range"}},
      {"offTooMuchColour.off", kOffHead + "3 0 1 2 1 1 1 1 1\n", {"line 6", "at most a colour"}},
      {"offNan.off", "OFF\n3 1 0\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n", {"line 4", "non-finite"}},
      {"absurdVertices.off", "OFF\n999999999999 1 0\n", {"line 2", "too many vertices"}},
      {"absurdFaces.off", "OFF\n3 99999999999999 0\n0 0 0\n", {"line 2", "more lines than"}},
      {"badCounts.off", "OFF\nthree 1 0\n", {"line 2", "'three' is not a count"}},
      {"countsMissing.off", "OFF\n", {"line 1", "before the counts"}},
      {"fourD.off", "4OFF\n3 1 0\n", {"line 1", "not supported"}},
      {"binaryOff.off", "OFF BINARY\n", {"line 1", "binary OFF"}},
  };
}

TEST(MeshInputErrors, EachMalformedFileIsOneLinePromptly) {
  const TempDir dir;
  for (const BadFile& bad : badFiles()) {
    SCOPED_TRACE(bad.name);
    const std::string path = dir.write(bad.name, bad.bytes);
    const auto start = std::chrono::steady_clock::now();
    try {
      (void)readMesh(path);
      ADD_FAILURE() << "no InputError";
    } catch (const InputError& e) {
      const std::string message = e.what();
      EXPECT_EQ(message.find('\n'), std::string::npos) << message;
      EXPECT_EQ(message.rfind("mesh file '" + path + "', ", 0), 0u) << message;
      for (const auto& part : bad.parts)
        EXPECT_NE(message.find(part), std::string::npos) << message;
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_LT(seconds, 1.0);
  }
}

TEST(MeshInputErrors, FromMemoryNamesTheFormat) {
  for (const BadFile& bad : badFiles()) {
    SCOPED_TRACE(bad.name);
    const std::string format = bad.name.substr(bad.name.rfind('.') + 1);
    try {
      (void)readMeshFromMemory(bad.bytes, format.c_str());
      ADD_FAILURE() << "no InputError";
    } catch (const InputError& e) {
      const std::string message = e.what();
      EXPECT_EQ(message.rfind("in-memory mesh (" + format + "), ", 0), 0u) << message;
      EXPECT_NE(message.find(bad.parts.front()), std::string::npos) << message;
    }
  }
}

TEST(MeshInputErrors, UnknownFormatGoesToAssimpAndIsRejected) {
  const TempDir dir;
  const std::string path = dir.write("mesh.xyz", "this is not a mesh\n");
  try {
    (void)readMesh(path);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot read mesh file '" + path + "'"),
              std::string::npos);
  }
  EXPECT_THROW((void)readMeshFromMemory("junk", "nosuchformat"), InputError);
}

}  // namespace
}  // namespace voxcut
