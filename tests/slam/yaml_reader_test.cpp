// The YAML reader of settings and sensor files (slam/dataset/yaml_reader.hpp): the files it must
// read (ORB-SLAM2 / OpenCV FileStorage settings, EuRoC sensor.yaml), the types of its scalars, and
// a message with the line for every malformed or unsupported construct, including the inputs on
// which OpenCV 4.6's parser hung (found by fuzzing).
#if PORTA_DATASET_BUILT

#include "slam/dataset/yaml_reader.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace porta::slam::detail {
namespace {

using Kind = YamlNode::Kind;

std::string error_of(const std::string& content) {
  try {
    parse_yaml(content);
  } catch (const YamlError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected a YamlError for: " << content;
  return {};
}

TEST(YamlReader, ReadsAnOpenCVSettingsFile) {
  const YamlNode root = parse_yaml(
      "%YAML:1.0\n---\n# comment\nCamera.fx: 718.856   # trailing comment\nCamera.width: 1242\n"
      "Camera.name: 'left'\nLEFT.K: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
      "   data: [ 1., 0., 2.5e+2, 0.,\n       1., -3.25E-1, 0., 0., 1. ]\nEmpty:\n");
  ASSERT_EQ(root.kind, Kind::map);
  ASSERT_EQ(root.entries.size(), 5u);
  EXPECT_EQ(root.entries[0].key, "Camera.fx");  // file order is kept
  const YamlNode* fx = root.find("Camera.fx");
  ASSERT_NE(fx, nullptr);
  EXPECT_EQ(fx->kind, Kind::real);
  EXPECT_EQ(fx->number, 718.856);
  EXPECT_EQ(fx->line, 4);
  EXPECT_EQ(root.find("Camera.width")->kind, Kind::integer);
  EXPECT_EQ(root.find("Camera.width")->number, 1242.0);
  EXPECT_EQ(root.find("Camera.name")->kind, Kind::text);
  EXPECT_EQ(root.find("Camera.name")->text, "left");
  const YamlNode* k = root.find("LEFT.K");
  ASSERT_NE(k, nullptr);
  EXPECT_EQ(k->kind, Kind::map);
  EXPECT_EQ(k->tag, "!!opencv-matrix");
  EXPECT_EQ(k->find("dt")->text, "d");
  const YamlNode* data = k->find("data");
  ASSERT_EQ(data->kind, Kind::list);
  ASSERT_EQ(data->items.size(), 9u);
  EXPECT_EQ(data->items[0].number, 1.0);
  EXPECT_EQ(data->items[2].number, 250.0);
  EXPECT_EQ(data->items[5].number, -0.325);
  EXPECT_EQ(data->items[5].line, 12);
  EXPECT_TRUE(root.find("Empty")->is_null());
  EXPECT_EQ(root.find("Missing"), nullptr);
}

TEST(YamlReader, ReadsAEurocSensorFile) {
  // The layout of EuRoC's cam0/sensor.yaml: no directive, a nested map, a flow list over lines
  // whose continuation lines are indented unevenly, comments after values.
  const YamlNode root = parse_yaml(
      "# General sensor definitions.\nsensor_type: camera\ncomment: VI-Sensor cam0 (MT9M034)\n\n"
      "T_BS:\n  cols: 4\n  rows: 4\n  data: [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,\n"
      "         0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,\n"
      "        -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,\n"
      "         0.0, 0.0, 0.0, 1.0]\n\nrate_hz: 20\nresolution: [752, 480]\ncamera_model: pinhole\n"
      "intrinsics: [458.654, 457.296, 367.215, 248.375] #fu, fv, cu, cv\n"
      "distortion_model: radial-tangential\ndistortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, "
      "1.76187114e-05]\n");
  EXPECT_EQ(root.find("comment")->text, "VI-Sensor cam0 (MT9M034)");
  const YamlNode* data = root.find("T_BS")->find("data");
  ASSERT_EQ(data->items.size(), 16u);
  EXPECT_EQ(data->items[8].number, -0.0257744366974);
  EXPECT_EQ(root.find("intrinsics")->items.size(), 4u);
  EXPECT_EQ(root.find("distortion_coefficients")->items[3].number, 1.76187114e-05);
  EXPECT_EQ(root.find("camera_model")->text, "pinhole");
}

TEST(YamlReader, BlockListsFlowMapsQuotesAndLineEnds) {
  const YamlNode root = parse_yaml(
      "list:\n- 1\n- [2, 3]\n-\n  - nested\n- key: value\n  other: 2\nindented:\n  - a\n  - 'it''s'\n"
      "flow: {a: 1, \"b c\": [x, y], }\nescaped: \"tab\\there \\\"q\\\"\"\r\ncrlf: 5\r\n...\n");
  const YamlNode* list = root.find("list");
  ASSERT_EQ(list->kind, Kind::list);
  ASSERT_EQ(list->items.size(), 4u);
  EXPECT_EQ(list->items[0].number, 1.0);
  EXPECT_EQ(list->items[1].items.size(), 2u);
  EXPECT_EQ(list->items[2].items[0].text, "nested");
  EXPECT_EQ(list->items[3].find("other")->number, 2.0);
  EXPECT_EQ(root.find("indented")->items[1].text, "it's");
  const YamlNode* flow = root.find("flow");
  ASSERT_EQ(flow->kind, Kind::map);
  EXPECT_EQ(flow->find("b c")->items[1].text, "y");
  EXPECT_EQ(root.find("escaped")->text, "tab\there \"q\"");
  EXPECT_EQ(root.find("crlf")->number, 5.0);
}

TEST(YamlReader, TypesPlainScalarsAsTheCoreSchema) {
  const YamlNode root = parse_yaml(
      "a: 007\nb: -2147483648\nc: 2147483647\nd: 1.\ne: .5\nf: -.inf\ng: .nan\nh: 1e400\ni: 1e-400\nj: ~\n"
      "k: 0x10\nl: '12'\nm: 1.5.2\nn: +3\no: text: with a colon\n");
  EXPECT_EQ(root.find("a")->kind, Kind::integer);
  EXPECT_EQ(root.find("a")->number, 7.0);
  EXPECT_EQ(root.find("b")->number, -2147483648.0);
  EXPECT_EQ(root.find("c")->number, 2147483647.0);
  EXPECT_EQ(root.find("d")->kind, Kind::real);
  EXPECT_EQ(root.find("d")->number, 1.0);
  EXPECT_EQ(root.find("e")->number, 0.5);
  EXPECT_EQ(root.find("f")->number, -INFINITY);
  EXPECT_TRUE(std::isnan(root.find("g")->number));
  EXPECT_EQ(root.find("h")->number, INFINITY);  // beyond double: infinite, refused by the users' checks
  EXPECT_EQ(root.find("i")->number, 0.0);
  EXPECT_TRUE(root.find("j")->is_null());
  EXPECT_EQ(root.find("k")->kind, Kind::text);
  EXPECT_EQ(root.find("l")->kind, Kind::text);  // quoted: a text, as YAML says
  EXPECT_EQ(root.find("m")->kind, Kind::text);
  EXPECT_EQ(root.find("n")->number, 3.0);
  EXPECT_EQ(root.find("o")->text, "text: with a colon");  // as OpenCV reads it (strict YAML refuses it)
}

TEST(YamlReader, IntegersBeyond32BitsAreRefusedWithTheirLine) {
  EXPECT_EQ(error_of("a: 1\nb: 4294968538\n"), "line 2: the integer 4294968538 is out of range (beyond 32 bits)");
  EXPECT_EQ(error_of("a: [1, -2147483649]\n"), "line 1: the integer -2147483649 is out of range (beyond 32 bits)");
  EXPECT_EQ(error_of("a: 99999999999999999999999\n"),
            "line 1: the integer 99999999999999999999999 is out of range (beyond 32 bits)");
}

TEST(YamlReader, MalformedDocumentsNameTheLine) {
  EXPECT_EQ(error_of("This is a README, not a settings file.\n"),
            "line 1: expected 'key: value', found 'This is a README, not a settings file.'");
  EXPECT_EQ(error_of("a: 1\nb: [1, 2\n"), "line 2: the list opened with '[' is not closed with ']'");
  EXPECT_EQ(error_of("a: {x: 1\n"), "line 1: the map opened with '{' is not closed with '}'");
  EXPECT_EQ(error_of("a: [1 [2]]\n"), "line 1: expected ',' or ']', found '[2]]'");
  EXPECT_EQ(error_of("a: [1,, 2]\n"), "line 1: an empty entry (two commas in a row?)");
  EXPECT_EQ(error_of("a: 1\n  b: 2\n"), "line 2: is indented more than the key above it");
  EXPECT_EQ(error_of("  a: 1\n b: 2\n"), "line 2: is indented less than the first key (line 1)");
  EXPECT_EQ(error_of("a: 1\na: 2\n"), "line 2: the key 'a' appears twice (first on line 1)");
  EXPECT_EQ(error_of("a: 'open\n"), "line 1: the quoted text is not closed on its line (' ... ')");
  EXPECT_EQ(error_of("a: \"\\q\"\n"), "line 1: the escape '\\q' is not supported");
  EXPECT_EQ(error_of("a: [1]  x\n"), "line 1: unexpected 'x' after the value");
  EXPECT_EQ(error_of("a: 1\n- b\n"), "line 2: a list entry ('- ') where a key was expected");
  EXPECT_EQ(error_of("\ta: 1\n"), "line 1: a tab in the indentation (YAML indents with spaces)");
  EXPECT_EQ(error_of("a: 1\x01\n"), "line 1: a control character (0x01) is not allowed in a YAML file");
  EXPECT_EQ(error_of("a: 1\n---\nb: 2\n"), "line 2: a second document ('---') is not supported");
  EXPECT_EQ(error_of("a: 1\n...\nb: 2\n"), "line 3: content after the end of the document ('...')");
}

TEST(YamlReader, UnsupportedConstructsAreRefusedNotMisread) {
  EXPECT_EQ(error_of("a: |\n  text\n"), "line 1: block scalars ('|' and '>') are not supported");
  EXPECT_EQ(error_of("a: &x 1\nb: *x\n"), "line 1: anchors and aliases ('&', '*') are not supported");
  EXPECT_EQ(error_of("? a\n: 1\n"), "line 1: complex keys ('? ') are not supported");
  EXPECT_EQ(error_of("a: @b\n"), "line 1: a value cannot start with '@' (a reserved character; quote the text)");
  EXPECT_EQ(error_of("a:\n  text on its own line\n"),
            "line 2: expected 'key: value', found 'text on its own line'");
}

TEST(YamlReader, NestingIsBounded) {
  std::string deep = "a: ";
  for (int i = 0; i < 200; ++i) deep += '[';
  EXPECT_NE(error_of(deep).find("nested more than 64 levels deep"), std::string::npos);
  std::string block;
  for (int i = 0; i < 100; ++i) block += std::string(static_cast<std::size_t>(i), ' ') + "k:\n";
  EXPECT_NE(error_of(block).find("nested more than 64 levels deep"), std::string::npos);
  std::string dashes;
  for (int i = 0; i < 100; ++i) dashes += "- ";
  EXPECT_NE(error_of(dashes + "x\n").find("nested more than 64 levels deep"), std::string::npos);
  std::string fine = "a: ";
  for (int i = 0; i < 30; ++i) fine += '[';
  fine += '1';
  for (int i = 0; i < 30; ++i) fine += ']';
  EXPECT_NO_THROW(parse_yaml(fine));
}

TEST(YamlReader, InputsThatHungOpenCVsParserAreRefused) {
  // Each of these made OpenCV 4.6's FileStorage loop forever or throw from inside (fuzzing,
  // docs/RELIABILITY.md); here each is refused with its line at once.
  EXPECT_EQ(error_of("---- 5\n-\n-"), "line 1: expected 'key: value', found '---- 5'");
  EXPECT_EQ(error_of(" t:d\n3, -\n\n"), "line 1: expected 'key: value', found 't:d'");
  EXPECT_NE(error_of(" o%Y, CALIfpsdt: d\n \n\n--------,\n Camera.fps# 0000no   ls: ------/--- 0.0------,-")
                .find("line 4: "),
            std::string::npos);
}

TEST(YamlReader, ADocumentOfCommentsHasNoRoot) {
  EXPECT_TRUE(parse_yaml("%YAML:1.0\n# nothing\n---\n").is_null());
  const YamlNode list = parse_yaml("- 1\n- 2\n");
  EXPECT_EQ(list.kind, Kind::list);
}

}  // namespace
}  // namespace porta::slam::detail

#endif  // PORTA_DATASET_BUILT
