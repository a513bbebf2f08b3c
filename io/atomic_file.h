#pragma once
// One checked, atomic writer for every file owlcal writes: under its final name a file is either
// what was there before or the whole new text, never a part of it.
//
//   io::WriteFileAtomic(out + "/ranges.csv", csv);  // throws "…/ranges.csv: write failed: No space left on device"
//
// The text goes to NAME.tmp-PID in the same folder, is flushed and closed with every step checked,
// and is then renamed into place; on any failure the temporary is removed and the previous file (if
// any) is left as it was. A target that exists and is not a regular file (/dev/null, /dev/full, a
// FIFO) cannot be replaced by a rename and is written in place, with the same checks. A symbolic
// link is followed, so the file it points at is replaced and the link kept.
#include <string>
#include <string_view>

namespace owlcal::io {

// Writes `data` to `path` (see above). Throws std::runtime_error naming the file and the system's
// reason (strerror) when it cannot be created, written, flushed, closed or renamed.
void WriteFileAtomic(const std::string& path, std::string_view data);

// True for the name of a temporary WriteFileAtomic leaves when killed ("x.csv.tmp-123") and for the
// older "x.csv.tmp", so a reader can skip it and a repair can remove it.
bool IsAtomicTemporary(const std::string& file_name);

}  // namespace owlcal::io
