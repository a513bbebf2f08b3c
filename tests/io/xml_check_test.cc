#include "io/xml_check.h"

#include <gtest/gtest.h>

namespace owlcal::io {
namespace {

TEST(XmlWellFormed, AcceptsOpenCvFileStorageXml) {
  EXPECT_EQ(
      XmlWellFormedError("<?xml version=\"1.0\"?>\n<opencv_storage>\n<!-- a comment -->\n"
                         "<M1 type_id=\"opencv-matrix\"><rows>1</rows><cols>1</cols><dt>d</dt><data>1.</data></M1>\n"
                         "<empty/><unit>mm</unit>\n</opencv_storage>\n"),
      "");
}

TEST(XmlWellFormed, NamesTheLineOfTheFirstProblem) {
  EXPECT_EQ(XmlWellFormedError("<?xml t_idversn="), "1: attribute 't_idversn' value not quoted");
  EXPECT_EQ(XmlWellFormedError("<?xml version=\"1.0\""), "1: tag not closed (the text ends inside it)");
  EXPECT_EQ(XmlWellFormedError("<a>\n<b>1</b>\n"), "3: the text ends inside <a> (truncated?)");
  EXPECT_EQ(XmlWellFormedError("<a>\n<b>1</c>\n</a>"), "2: </c> closes <b>");
  EXPECT_EQ(XmlWellFormedError("<a></a><b/>"), "1: a second root element <b>");
  EXPECT_EQ(XmlWellFormedError("<a>\n<!-- open\n</a>"), "2: comment not closed ('-->' missing)");
  EXPECT_EQ(XmlWellFormedError("<a x=\"1></a>"), "1: attribute 'x' value not closed");
  EXPECT_EQ(XmlWellFormedError("<a>\x01</a>"), "1: control character 1 in the text");
  EXPECT_EQ(XmlWellFormedError("  \n"), "2: no root element");
  EXPECT_EQ(XmlWellFormedError("<a>< b/></a>"), "1: '<' not followed by a tag name");
  EXPECT_EQ(XmlWellFormedError("x<a/>"), "1: text outside the root element");
}

}  // namespace
}  // namespace owlcal::io
