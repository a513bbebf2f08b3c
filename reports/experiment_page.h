#pragma once
// The one-page report of an eye-movement experiment (owlcal vor, main-sequence, catch-up, track):
// a heading and an introduction, the figures (or where their data is when gnuplot could not draw
// them), the tables, the notes and failures, and what follows them.
#include <string>
#include <vector>

#include "reports/gnuplot_figure.h"

namespace owlcal::reports {

struct ExperimentPage {
  std::string title;            // after "owlcal " in <title>
  std::string heading;          // <h1>
  std::string intro_html;       // the introduction paragraph's contents, already escaped
  std::vector<Figure> figures;  // with files[i] as WriteFigure returned them
  std::vector<FigureFiles> files;
  std::string tables_html;         // above the notes
  std::vector<std::string> notes;  // "Notes and failures", escaped here
  std::string after_notes_html;    // below the notes
};

// Writes OUT/report/index.html and returns its path.
std::string WriteExperimentPage(const ExperimentPage& page, const std::string& out_dir);

}  // namespace owlcal::reports
