// A well-formedness check for XML text before OpenCV's FileStorage parses it. FileStorage's XML
// parser reads past the end of truncated or malformed text (a bare "<?xml t_idversn=" made it
// dereference a null pointer: found by fuzz/course_xml_fuzz), so owlcal hands it only text that
// is well formed: a closed XML declaration, names, quoted attributes, closed comments, balanced
// elements, one root element, and no control characters.
#ifndef OWLCAL_IO_XML_CHECK_H_
#define OWLCAL_IO_XML_CHECK_H_

#include <string>
#include <string_view>

namespace owlcal::io {

// "" when `text` is well-formed XML, else the first problem as "LINE: what" (LINE from 1).
std::string XmlWellFormedError(std::string_view text);

}  // namespace owlcal::io

#endif  // OWLCAL_IO_XML_CHECK_H_
