#include "calib/target_sheet.h"
#include "io/number_text.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>

namespace owlcal::calib {
namespace {

std::string Fixed(double v, int digits) { return io::FixedText(v, digits); }

struct Paper {
  std::string name;
  double w_mm, h_mm;  // portrait
};

// "WxH" in millimetres; false if `s` is not of that form.
bool ParseCustomPaper(const std::string& s, double* w, double* h) {
  const size_t x = s.find_first_of("xX");
  if (x == std::string::npos) return false;
  char* end = nullptr;
  const std::string a = s.substr(0, x), b = s.substr(x + 1);
  *w = std::strtod(a.c_str(), &end);
  if (a.empty() || *end) return false;
  *h = std::strtod(b.c_str(), &end);
  if (b.empty() || *end) return false;
  return *w > 0 && *h > 0 && std::isfinite(*w) && std::isfinite(*h);
}

std::vector<Paper> Candidates(const std::string& paper) {
  const std::vector<Paper> iso = {
      {"A4", 210, 297}, {"A3", 297, 420}, {"A2", 420, 594}, {"A1", 594, 841}, {"A0", 841, 1189}};
  if (paper == "auto") return iso;
  std::string up = paper;
  std::transform(up.begin(), up.end(), up.begin(), ::toupper);
  for (const Paper& p : iso)
    if (p.name == up) return {p};
  if (up == "LETTER") return {{"Letter", 215.9, 279.4}};
  if (up == "LEGAL") return {{"Legal", 215.9, 355.6}};
  double w = 0, h = 0;
  if (ParseCustomPaper(paper, &w, &h)) return {{Fixed(w, 1) + " x " + Fixed(h, 1) + " mm", w, h}};
  return {};
}

// Generous width estimate of Helvetica text (average advance <= 0.56 em for mixed text).
double TextWidthMm(const std::string& text, double size_mm) { return 0.56 * size_mm * double(text.size()); }

// Black rectangles of the pattern in the target frame [mm], and the quiet zone [mm] the
// detector needs around them.
struct Pattern {
  std::vector<SheetRect> black;  // target frame, mm
  double x0, y0, x1, y1;         // black extent, target frame, mm
  double quiet_mm;
};

Pattern MakePattern(const TargetDefinition& t) {
  Pattern p;
  switch (t.kind) {
    case TargetKind::kChessboard: {
      if (t.cols < 2 || t.rows < 2)
        throw std::invalid_argument("target '" + t.id + "': a chessboard needs >= 2 x 2 inner corners");
      if (!(t.square_m > 0)) throw std::invalid_argument("target '" + t.id + "': square size must be > 0");
      const double s = 1000 * t.square_m;
      for (int j = -1; j < t.rows; ++j)
        for (int i = -1; i < t.cols; ++i)
          if (((i + j) & 1) == 0) p.black.push_back({i * s, j * s, s, s});
      p.x0 = -s, p.y0 = -s, p.x1 = t.cols * s, p.y1 = t.rows * s;
      // findChessboardCorners needs white paper around the outer squares to close their quads;
      // half a square (at most 15 mm) is ample and lets a 10 x 7 board of 18 mm squares fit A4.
      p.quiet_mm = std::min(0.5 * s, 15.0);
      break;
    }
    case TargetKind::kAprilGrid: {
      if (t.family != "tag36h11")
        throw std::invalid_argument("target '" + t.id + "': family '" + t.family +
                                    "' cannot be printed (only tag36h11)");
      if (t.tag_cols < 1 || t.tag_rows < 1) throw std::invalid_argument("target '" + t.id + "': needs >= 1 x 1 tags");
      if (!(t.tag_size_m > 0) || !(t.tag_spacing >= 0))
        throw std::invalid_argument("target '" + t.id + "': tag size must be > 0 and spacing >= 0");
      apriltag_family_t* fam = tag36h11_create();
      const int last_id = t.first_id + t.tag_cols * t.tag_rows - 1;
      if (t.first_id < 0 || last_id >= int(fam->ncodes)) {
        const int n = int(fam->ncodes);
        tag36h11_destroy(fam);
        throw std::invalid_argument("target '" + t.id + "': tag ids " + std::to_string(t.first_id) + ".." +
                                    std::to_string(last_id) + " outside tag36h11 (0.." + std::to_string(n - 1) + ")");
      }
      const double size = 1000 * t.tag_size_m, bit = size / fam->width_at_border;
      const double pitch = size * (1 + t.tag_spacing);
      const int b = (fam->total_width - fam->width_at_border) / 2;  // white bits around the border
      for (int r = 0; r < t.tag_rows; ++r)
        for (int c = 0; c < t.tag_cols; ++c) {
          image_u8_t* tag = apriltag_to_image(fam, t.first_id + r * t.tag_cols + c);
          for (int y = 0; y < tag->height; ++y) {
            int x = 0;
            while (x < tag->width) {  // one rectangle per horizontal run of black bits
              if (tag->buf[y * tag->stride + x] >= 128) {
                ++x;
                continue;
              }
              const int start = x;
              while (x < tag->width && tag->buf[y * tag->stride + x] < 128) ++x;
              p.black.push_back({c * pitch + (start - b) * bit, r * pitch + (y - b) * bit, (x - start) * bit, bit});
            }
          }
          // image_u8_destroy is not exported by Debian's libapriltag; it frees these two.
          free(tag->buf);
          free(tag);
        }
      tag36h11_destroy(fam);
      p.x0 = 0, p.y0 = 0, p.x1 = (t.tag_cols - 1) * pitch + size, p.y1 = (t.tag_rows - 1) * pitch + size;
      // libapriltag needs the white bit around each tag; the grid's own gap is the usual margin.
      p.quiet_mm = std::max(bit, size * t.tag_spacing);
      break;
    }
    case TargetKind::kFixation:
      throw std::invalid_argument("target '" + t.id + "': a fixation target cannot be printed as a calibration sheet");
  }
  return p;
}

constexpr double kTitleMm = 5.0, kLineMm = 3.4, kLabelMm = 2.8;
constexpr double kBarHeightMm = 2.0, kTickMm = 3.0, kTickWidthMm = 0.3;

}  // namespace

bool TargetSheetOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "TargetSheetOptions." + m;
    return false;
  };
  if (Candidates(paper).empty())
    return fail("paper must be auto, A0..A4, letter, legal or WxH in mm, got '" + paper + "'");
  if (!(printer_margin_mm >= 0) || printer_margin_mm > 50)
    return fail("printer_margin_mm must be 0..50, got " + Fixed(printer_margin_mm, 2));
  if (!(scale_bar_mm >= 10) || scale_bar_mm > 1000)
    return fail("scale_bar_mm must be 10..1000, got " + Fixed(scale_bar_mm, 2));
  for (char c : note)
    if (c < 32 || c > 126) return fail("note must be printable ASCII");
  return true;
}

std::string DescribeTargetDimensions(const TargetDefinition& t) {
  const Eigen::Vector4d e = t.Extent();
  switch (t.kind) {
    case TargetKind::kChessboard:
      return "chessboard " + std::to_string(t.cols) + " x " + std::to_string(t.rows) + " inner corners (" +
             std::to_string(t.cols + 1) + " x " + std::to_string(t.rows + 1) + " squares), square " +
             Fixed(1000 * t.square_m, 2) + " mm, pattern " + Fixed(1000 * (e[1] - e[0]), 1) + " x " +
             Fixed(1000 * (e[3] - e[2]), 1) + " mm";
    case TargetKind::kAprilGrid: {
      const double size = 1000 * t.tag_size_m, pitch = size * (1 + t.tag_spacing);
      return "AprilGrid " + std::to_string(t.tag_cols) + " x " + std::to_string(t.tag_rows) + " " + t.family +
             ", ids " + std::to_string(t.first_id) + "-" + std::to_string(t.first_id + t.tag_cols * t.tag_rows - 1) +
             ", tag " + Fixed(size, 2) + " mm, gap " + Fixed(size * t.tag_spacing, 2) + " mm (tagSpacing " +
             Fixed(t.tag_spacing, 3) + "), tags span " + Fixed((t.tag_cols - 1) * pitch + size, 1) + " x " +
             Fixed((t.tag_rows - 1) * pitch + size, 1) + " mm";
    }
    case TargetKind::kFixation:
      return "fixation disc, radius " + Fixed(1000 * t.fixation_radius_m, 1) + " mm";
  }
  return "";
}

TargetSheet LayoutTargetSheet(const TargetDefinition& target, const TargetSheetOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw std::invalid_argument(why);
  const Pattern pat = MakePattern(target);
  const double pw = pat.x1 - pat.x0, ph = pat.y1 - pat.y0, q = pat.quiet_mm, m = options.printer_margin_mm;

  std::vector<std::string> head = {"owlcal calibration target '" + target.id + "'",
                                   DescribeTargetDimensions(target),
                                   "Print at 100 % (actual size, no fit-to-page); mount flat and rigid."};
  if (!options.note.empty()) head.push_back(options.note);
  const double head_mm = kTitleMm + 1.6 * kLineMm * double(head.size() - 1) + 1.0;
  // Below the pattern: ticks, bar, tick labels, one line of instructions.
  const double foot_mm = kTickMm + kBarHeightMm + 1.5 + kLabelMm + 1.8 * kLineMm;

  std::string tried;
  for (const Paper& paper : Candidates(options.paper)) {
    for (int turn = 0; turn < 2; ++turn) {
      const int landscape = pw > ph ? 1 - turn : turn;  // a wide pattern tries landscape first
      const double W = landscape ? paper.h_mm : paper.w_mm, H = landscape ? paper.w_mm : paper.h_mm;
      if (landscape && paper.w_mm == paper.h_mm) continue;
      // The pattern's quiet zone may overlap the printer margin (both are white), the text may not.
      const double need_w = pw + 2 * std::max(q, m);
      const double need_h = m + head_mm + q + ph + q + foot_mm + m;
      tried += (tried.empty() ? "" : ", ") + paper.name + (landscape ? " landscape" : " portrait") + " " + Fixed(W, 0) +
               " x " + Fixed(H, 0);
      if (need_w > W || need_h > H) continue;
      TargetSheet s;
      s.width_mm = W, s.height_mm = H;
      s.paper_name = paper.name + (paper.w_mm == paper.h_mm ? "" : landscape ? " landscape" : " portrait");
      // Centre the whole block (text, pattern, scale) on the page.
      const double top = (H - (need_h - 2 * m)) / 2;
      const double px = (W - pw) / 2, py = top + head_mm + q;
      s.target_origin_mm = Eigen::Vector2d(px - pat.x0, py - pat.y0);
      for (const SheetRect& r : pat.black)
        s.black.push_back({s.target_origin_mm.x() + r.x_mm, s.target_origin_mm.y() + r.y_mm, r.w_mm, r.h_mm});
      const Eigen::Vector4d e = target.Extent();
      s.pattern_mm = {s.target_origin_mm.x() + 1000 * e[0],
                      s.target_origin_mm.y() + 1000 * e[2],
                      1000 * (e[1] - e[0]),
                      1000 * (e[3] - e[2])};
      // Text starts at the pattern's left edge, or at the margin when the pattern is wider.
      const double text_x = std::max(m, std::min(px, W / 2 - 80));
      const double text_w = W - m - text_x;
      double y = top + kTitleMm;
      for (size_t i = 0; i < head.size(); ++i) {
        double size = i == 0 ? kTitleMm : kLineMm;
        size = std::min(size, text_w / std::max(1e-9, TextWidthMm(head[i], 1.0)));
        s.texts.push_back({text_x, y, size, head[i]});
        y += 1.6 * kLineMm;
      }
      // Scale bar: a whole number of centimetres, ticks every 10 mm (taller every 50 mm).
      const double bar = std::min(options.scale_bar_mm, std::floor((W - 2 * m) / 10) * 10);
      const double bar_x = std::max(m, std::min(px, W - m - bar));
      const double tick_y = py + ph + q;
      const double bar_y = tick_y + kTickMm;
      s.scale_bar_mm = {bar_x, bar_y, bar, kBarHeightMm};
      s.scale_bar_length_mm = bar;
      s.black.push_back(s.scale_bar_mm);
      const int num_cm = int(std::lround(bar / 10));
      for (int k = 0; k <= num_cm; ++k) {
        const double len = (k % 5 == 0 || k == num_cm) ? kTickMm : 0.6 * kTickMm;
        const double x = std::clamp(bar_x + 10.0 * k - kTickWidthMm / 2, bar_x, bar_x + bar - kTickWidthMm);
        s.black.push_back({x, bar_y - len, kTickWidthMm, len});
        if (k % 5 != 0 && k != num_cm) continue;
        const std::string label = std::to_string(10 * k) + (k == num_cm ? " mm" : "");
        const double lx = k == 0 ? bar_x : x - 0.28 * kLabelMm * double(std::to_string(10 * k).size());
        s.texts.push_back({lx, bar_y + kBarHeightMm + 1.5 + kLabelMm * 0.8, kLabelMm, label});
      }
      const std::string check = "Scale check: the bar must measure " + Fixed(bar, 0) + " mm and the black pattern " +
                                Fixed(pw, 1) + " x " + Fixed(ph, 1) + " mm. If not, correct the target YAML.";
      double size = std::min(kLineMm * 0.9, text_w / std::max(1e-9, TextWidthMm(check, 1.0)));
      s.texts.push_back({text_x, bar_y + kBarHeightMm + 1.5 + kLabelMm + 1.6 * kLineMm, size, check});
      return s;
    }
  }
  throw std::invalid_argument("target '" + target.id + "' (" + DescribeTargetDimensions(target) + ", with " +
                              Fixed(head_mm + foot_mm, 0) + " mm of text and scale bar, " + Fixed(m, 0) +
                              " mm printer margins) does not fit on " + tried +
                              " mm: choose a larger paper or a smaller square/tag size");
}

std::string TargetSheetSvg(const TargetSheet& s) {
  std::ostringstream o;
  o << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    << "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"" << Fixed(s.width_mm, 3) << "mm\" height=\""
    << Fixed(s.height_mm, 3) << "mm\" viewBox=\"0 0 " << Fixed(s.width_mm, 3) << " " << Fixed(s.height_mm, 3) << "\">\n"
    << "<title>" << (s.texts.empty() ? "owlcal target" : s.texts[0].text) << "</title>\n"
    << "<rect x=\"0\" y=\"0\" width=\"" << Fixed(s.width_mm, 3) << "\" height=\"" << Fixed(s.height_mm, 3)
    << "\" fill=\"#ffffff\"/>\n"
    << "<path fill=\"#000000\" fill-rule=\"nonzero\" d=\"";
  for (const SheetRect& r : s.black)
    o << "M" << Fixed(r.x_mm, 4) << " " << Fixed(r.y_mm, 4) << "h" << Fixed(r.w_mm, 4) << "v" << Fixed(r.h_mm, 4) << "h"
      << Fixed(-r.w_mm, 4) << "z";
  o << "\"/>\n";
  for (const SheetText& t : s.texts) {
    std::string esc;
    for (char c : t.text) esc += c == '<' ? "&lt;" : c == '>' ? "&gt;" : c == '&' ? "&amp;" : std::string(1, c);
    o << "<text x=\"" << Fixed(t.x_mm, 3) << "\" y=\"" << Fixed(t.y_mm, 3)
      << "\" font-family=\"Helvetica, Arial, sans-serif\" "
      << "font-size=\"" << Fixed(t.size_mm, 3) << "\" fill=\"#000000\">" << esc << "</text>\n";
  }
  o << "</svg>\n";
  return o.str();
}

std::string TargetSheetPdf(const TargetSheet& s) {
  const double k = 72.0 / 25.4;  // points per mm
  const double H = s.height_mm;
  std::ostringstream c;
  c << "1 1 1 rg 0 0 " << Fixed(s.width_mm * k, 4) << " " << Fixed(H * k, 4) << " re f\n0 0 0 rg\n";
  for (const SheetRect& r : s.black)
    c << Fixed(r.x_mm * k, 4) << " " << Fixed((H - r.y_mm - r.h_mm) * k, 4) << " " << Fixed(r.w_mm * k, 4) << " "
      << Fixed(r.h_mm * k, 4) << " re\n";
  c << "f\n";
  for (const SheetText& t : s.texts) {
    std::string esc;
    for (char ch : t.text) {
      if (ch == '(' || ch == ')' || ch == '\\') esc += '\\';
      esc += ch;
    }
    c << "BT /F1 " << Fixed(t.size_mm * k, 3) << " Tf " << Fixed(t.x_mm * k, 3) << " " << Fixed((H - t.y_mm) * k, 3)
      << " Td (" << esc << ") Tj ET\n";
  }
  const std::string content = c.str();
  std::vector<std::string> objects = {
      "<< /Type /Catalog /Pages 2 0 R >>",
      "<< /Type /Pages /Kids [3 0 R] /Count 1 >>",
      "<< /Type /Page /Parent 2 0 R /MediaBox [0 0 " + Fixed(s.width_mm * k, 4) + " " + Fixed(H * k, 4) +
          "] /Resources << /Font << /F1 5 0 R >> >> /Contents 4 0 R >>",
      "<< /Length " + std::to_string(content.size()) + " >>\nstream\n" + content + "endstream",
      "<< /Type /Font /Subtype /Type1 /BaseFont /Helvetica /Encoding /WinAnsiEncoding >>",
      "<< /Title (owlcal calibration target) /Creator (owlcal target) >>"};
  std::string pdf = "%PDF-1.4\n%\xE2\xE3\xCF\xD3\n";
  std::vector<size_t> offsets;
  for (size_t i = 0; i < objects.size(); ++i) {
    offsets.push_back(pdf.size());
    pdf += std::to_string(i + 1) + " 0 obj\n" + objects[i] + "\nendobj\n";
  }
  const size_t xref = pdf.size();
  pdf += "xref\n0 " + std::to_string(objects.size() + 1) + "\n0000000000 65535 f \n";
  for (size_t off : offsets) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%010zu 00000 n \n", off);
    pdf += buf;
  }
  pdf += "trailer\n<< /Size " + std::to_string(objects.size() + 1) + " /Root 1 0 R /Info 6 0 R >>\nstartxref\n" +
         std::to_string(xref) + "\n%%EOF\n";
  return pdf;
}

}  // namespace owlcal::calib
