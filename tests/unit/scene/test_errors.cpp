// Bad input is refused with one line that says what is wrong and where (<file>:<line>), never loaded.
#include <gtest/gtest.h>

#include <fstream>

#include "radiosity/scene/rrv_reader.hpp"
#include "scene_test_util.hpp"

using radiosity::LoadOptions;
using scene_test::expect_refused;

namespace {

// The scene text puts the element under test on line 4 (head on 2, objectdef on 3).
std::string in_objectdef(const std::string& line4) {
  return "<scene>\n<head>\n<objectdef name='o'>\n" + line4 +
         "\n</objectdef>\n</head>\n"
         "<body><object name='o'/></body>\n</scene>\n";
}

const std::string kTriangle =
    "<triangle><vertex x='0' y='0' z='0'/><vertex x='1' y='0' z='0'/>"
    "<vertex x='0' y='1' z='0'/></triangle>";

void refused(const std::string& xml, const std::vector<std::string>& parts, const LoadOptions& opt = {}) {
  expect_refused([&] { radiosity::load_rrv_scene_string(xml, opt); }, parts);
}

}  // namespace

TEST(Errors, MalformedXmlNamesFileAndLine) {
  scene_test::TempDir tmp;
  const std::string path = (tmp.path() / "broken.xml").string();
  std::ofstream(path) << "<scene>\n<head>\n<objectdef name='o'>\n<cuboid>\n</objectdef>\n</head>\n</scene>\n";
  expect_refused([&] { radiosity::load_rrv_scene(path); }, {path + ":5:", "malformed XML"});
}

TEST(Errors, MissingFile) {
  expect_refused([] { radiosity::load_rrv_scene("/nonexistent/scene.xml"); }, {"/nonexistent/scene.xml"});
}

TEST(Errors, UnknownElements) {
  refused("<scene>\n<body>\n<translate dx='1'>\n<spin angle='3'/>\n</translate>\n</body>\n</scene>",
          {"<string>:4:", "unknown element <spin>"});
  refused(in_objectdef("<triangleset>" + kTriangle + "<polygon n='5'/></triangleset>"),
          {"<string>:4:", "unknown element <polygon>"});
  refused(in_objectdef("<triangleset><triangle><vertex x='0' y='0' z='0'/></triangle></triangleset>"),
          {"<string>:4:", "<triangle> needs exactly 3 <vertex>"});
  refused(in_objectdef("<triangleset><triangle><vertex x='0' y='0' z='0'/><vertex x='1' y='0' z='0'/><vertx/>"
                       "</triangle></triangleset>"),
          {"<string>:4:", "unknown element <vertx>"});
  refused("<scene>\n<head/>\n<tail/>\n</scene>", {"<string>:3:", "unknown element <tail>"});
  refused("<scene>\n<body>hello</body>\n</scene>", {"<string>:2:", "unexpected text"});
}

TEST(Errors, UnknownPrimitive) { refused(in_objectdef("<pyramid/>"), {"<string>:4:", "unknown primitive <pyramid>"}); }

TEST(Errors, UnknownAttribute) {
  // A misspelt colour would otherwise read as black.
  refused(in_objectdef("<cuboid reflectivty='.5,.5,.5'/>"), {"<string>:4:", "unknown attribute 'reflectivty'"});
}

TEST(Errors, ObjectNamingAnUndefinedObjectdef) {
  refused(
      "<scene>\n<head><objectdef name='a'><cuboid/></objectdef></head>\n<body>\n<object name='b'/>\n</body>\n</scene>",
      {"<string>:4:", "'b'", "objectdef"});
}

TEST(Errors, VertexCoordinates) {
  refused(in_objectdef("<triangleset><triangle><vertex x='0' y='0'/><vertex x='1' y='0' z='0'/>"
                       "<vertex x='0' y='1' z='0'/></triangle></triangleset>"),
          {"<string>:4:", "'z'"});
  refused(in_objectdef("<triangleset><triangle><vertex x='0' y='zero' z='0'/><vertex x='1' y='0' z='0'/>"
                       "<vertex x='0' y='1' z='0'/></triangle></triangleset>"),
          {"<string>:4:", "'y'", "not a number", "zero"});
  refused(in_objectdef("<triangleset><triangle><vertex x='0' y='inf' z='0'/><vertex x='1' y='0' z='0'/>"
                       "<vertex x='0' y='1' z='0'/></triangle></triangleset>"),
          {"<string>:4:", "not finite"});
  refused(in_objectdef("<triangleset><triangle><vertex x='0' y='1e999' z='0'/><vertex x='1' y='0' z='0'/>"
                       "<vertex x='0' y='1' z='0'/></triangle></triangleset>"),
          {"<string>:4:", "out of range"});
}

TEST(Errors, Colours) {
  refused(in_objectdef("<cuboid emission='nan,1,1'/>"), {"<string>:4:", "'emission'", "not finite"});
  refused(in_objectdef("<cuboid emission='inf,1,1'/>"), {"<string>:4:", "not finite"});
  refused(in_objectdef("<cuboid radiosity='1,-0.5,1'/>"), {"<string>:4:", "'radiosity'", "negative"});
  refused(in_objectdef("<cuboid reflectivity='.5,.5'/>"), {"<string>:4:", "three numbers"});
  refused(in_objectdef("<cuboid reflectivity='.5,.5,.5,.5'/>"), {"<string>:4:", "three numbers"});
  refused(in_objectdef("<cuboid reflectivity='.5,x,.5'/>"), {"<string>:4:", "three numbers"});
}

TEST(Errors, ReflectivityOfOneOrMoreUnlessAllowed) {
  refused(in_objectdef("<cuboid reflectivity='.5,1,.5'/>"), {"<string>:4:", "--allow-reflectivity-ge-1"});
  refused(in_objectdef("<triangleset reflectivity='.5,.5,.5'><triangle reflectivity='1.5,0,0'>"
                       "<vertex x='0' y='0' z='0'/><vertex x='1' y='0' z='0'/><vertex x='0' y='1' z='0'/>"
                       "</triangle></triangleset>"),
          {"<string>:4:", "--allow-reflectivity-ge-1"});
  LoadOptions allow;
  allow.allow_reflectivity_ge_1 = true;
  const radiosity::Mesh m = radiosity::load_rrv_scene_string(in_objectdef("<cuboid reflectivity='.5,1,.5'/>"), allow);
  EXPECT_EQ(m.patches[0].reflectivity, (radiosity::Rgb{.5, 1, .5}));
}

TEST(Errors, DegenerateTriangles) {
  // Collinear vertices, and a repeated vertex through a strip: the place is the element that made it.
  refused(in_objectdef("<triangleset>\n<triangle><vertex x='0' y='0' z='0'/><vertex x='1' y='1' z='1'/>"
                       "<vertex x='2' y='2' z='2'/></triangle></triangleset>"),
          {"<string>:5:", "degenerate triangle"});
  refused(in_objectdef("<triangleset>\n" + kTriangle +
                       "\n<trianglenext><vertex x='1' y='0' z='0'/></trianglenext>"
                       "</triangleset>"),
          {"<string>:6:", "degenerate triangle"});
  // A scale that names one axis collapses the other two (RRV's default 0): every triangle of the cube loses its area.
  refused(
      "<scene>\n<head><objectdef name='c'>\n<cuboid/>\n</objectdef></head>\n<body>\n<scale dx='2'>\n"
      "<object name='c'/>\n</scale></body></scene>",
      {"<string>:3:", "zero area", "line 7"});
}

TEST(Errors, StripsAndTransforms) {
  refused(in_objectdef("<triangleset><trianglenext><vertex x='0' y='0' z='0'/></trianglenext></triangleset>"),
          {"<string>:4:", "must follow a <triangle>"});
  refused(
      "<scene>\n<head><objectdef name='c'><cuboid/></objectdef></head>\n<body>\n<rotate angle='30'>"
      "<object name='c'/></rotate></body></scene>",
      {"<string>:4:", "non-zero axis"});
  refused(
      "<scene>\n<head><objectdef name='c'><cuboid/></objectdef></head>\n<body>\n<rotate dy='1'>"
      "<object name='c'/></rotate></body></scene>",
      {"<string>:4:", "'angle'"});
  refused(
      "<scene>\n<head><objectdef name='c'><cuboid/></objectdef></head>\n<body>\n<translate dx='1m'>"
      "<object name='c'/></translate></body></scene>",
      {"<string>:4:", "'dx'", "not a number"});
}

TEST(Errors, ObjectdefsAndEmptyScenes) {
  refused(
      "<scene>\n<head>\n<objectdef name='a'><cuboid/></objectdef>\n<objectdef name='a'><globe/></objectdef>\n"
      "</head></scene>",
      {"<string>:4:", "defined twice"});
  refused("<scene><head><objectdef name='a'><cuboid/></objectdef></head><body/></scene>", {"no triangles"});
  refused("<world/>", {"<string>:1:", "<scene>"});
}

TEST(Errors, DivideMustBePositive) {
  LoadOptions opt;
  opt.divide = 0;
  refused(in_objectdef("<cuboid/>"), {"--divide"}, opt);
}

TEST(Errors, TeapotWithoutTeapotObj) {
  scene_test::TempDir empty;
  scene_test::EnvGuard no_env("RRV_SCENES", nullptr);
  LoadOptions opt;
  opt.primitive_dir = empty.path().string();
  refused(in_objectdef("<teapot/>"), {"<string>:4:", "teapot.obj", empty.path().string(), "RRV_SCENES"}, opt);
}

// Found by fuzzing (tests/fuzz/regressions/scene): a vertex coordinate of 7e45 made one triangle subdivide
// until memory ran out. The patch count is bounded, and the message says where and what to change.
TEST(Errors, SubdivisionBeyondThePatchLimit) {
  const std::string big = "<triangleset><triangle><vertex x='0' y='0' z='0'/><vertex x='1e30' y='0' z='0'/>"
                          "<vertex x='0' y='1e30' z='0'/></triangle></triangleset>";
  refused(in_objectdef(big), {"<string>:", "more than 1048576 patches", "maximum patch area of 1", "--divide"});
  // The limit counts the whole scene, not one triangle: 3 instances of a 4-patch triangle exceed 10.
  LoadOptions opt;
  opt.max_patches = 10;
  const std::string four = "<triangleset><triangle><vertex x='0' y='0' z='0'/><vertex x='2' y='0' z='0'/>"
                           "<vertex x='0' y='2' z='0'/></triangle></triangleset>";
  const std::string three = "<scene><head><objectdef name='o'>" + four +
                            "</objectdef></head><body><object name='o'/><object name='o'/>\n<object name='o'/>"
                            "</body></scene>";
  refused(three, {"<string>:2:", "more than 10 patches"}, opt);
  opt.max_patches = 12;
  EXPECT_EQ(radiosity::load_rrv_scene_string(three, opt).size(), 12u);
}

TEST(Errors, TriangleOutOfRange) {
  // Each number is finite, their product is not: without the check the area is NaN and subdivision never ends.
  refused("<scene>\n<head>\n<objectdef name='o'>\n<cuboid/>\n</objectdef>\n</head>\n<body><scale dx='1e300' "
          "dy='1e300' dz='1e300'><scale dx='1e300' dy='1e300' dz='1e300'><object name='o'/></scale></scale></body>"
          "</scene>",
          {"<string>:4:", "out of range after the transforms"});
  refused("<scene>\n<head>\n<objectdef name='o'>\n<cuboid/>\n</objectdef>\n</head>\n<body><scale dx='1e200' "
          "dy='1e200' dz='1e200'><object name='o'/></scale></body></scene>",
          {"<string>:4:", "out of range after the transforms", "overflows"});
  // Coordinates of 1e200 are numbers, but the edge lengths overflow: refused as such, not as "zero area".
  refused(in_objectdef("<triangleset><triangle><vertex x='0' y='0' z='0'/><vertex x='1e200' y='0' z='0'/>"
                       "<vertex x='0' y='1' z='0'/></triangle></triangleset>"),
          {"<string>:4:", "triangle out of range (its size overflows a double)"});
}

// A refusal quotes the input, and XML can carry a line break inside a value (&#10;): it is shown escaped, so the
// message stays one line (tests/fuzz/regressions/scene/newline-*).
TEST(Errors, QuotedInputStaysOneLine) {
  refused(in_objectdef("<cuboid emission='x&#10;y,0,0'/>"), {"<string>:4:", "\"x\\x0ay,0,0\""});
  refused("<scene><head><objectdef name='o'><cuboid/></objectdef></head><body><object name='a&#13;b'/></body>"
          "</scene>",
          {"object 'a\\x0db' names no objectdef"});
}

TEST(Errors, AValueThatIsNotUtf8IsRefused) {
  // a Latin-1 byte, a stray continuation byte, an overlong '<': no name of a record, a message or the web page
  for (const std::string bad : {"caf\xe9", "x\x80y", "\xc0\xbc" "script"})
    refused(in_objectdef("<triangleset name='" + bad + "' emission='1,1,1' reflectivity='0.5,0.5,0.5'>" + kTriangle +
                         "</triangleset>"),
            {"<string>:4:", "attribute 'name' of <triangleset> is not UTF-8 text"});
  refused("<scene>\n<head>\n<objectdef name='\xff'>\n" + kTriangle + "\n</objectdef>\n</head>\n</scene>\n",
          {"<string>:3:", "is not UTF-8 text", "\\xff"});
}
