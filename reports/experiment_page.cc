#include "reports/experiment_page.h"

#include "reports/table.h"

namespace owlcal::reports {

std::string WriteExperimentPage(const ExperimentPage& p, const std::string& out_dir) {
  std::string html =
      "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>owlcal " + HtmlEscape(p.title) +
      "</title>\n<style>body{font-family:sans-serif;max-width:1100px;margin:auto;padding:1em}table{border-collapse:"
      "collapse;margin:1em 0}td,th{border:1px solid #bbb;padding:3px 8px}img{max-width:100%}</style></head><body>\n"
      "<h1>" +
      HtmlEscape(p.heading) + "</h1>\n<p>" + p.intro_html + "</p>\n";
  for (size_t i = 0; i < p.figures.size() && i < p.files.size(); ++i) {
    const Figure& f = p.figures[i];
    if (p.files[i].drawn)
      html += "<figure><img src=\"../figures/" + f.name + ".png\" alt=\"" + HtmlEscape(f.title) + "\"><figcaption>" +
              HtmlEscape(f.caption) + "</figcaption></figure>\n";
    else
      html += "<p>Figure " + f.name + " not drawn (" + HtmlEscape(p.files[i].message) + "): figures/" + f.name +
              ".gp and .csv hold its data.</p>\n";
  }
  html += p.tables_html;
  if (!p.notes.empty()) {
    html += "<h2>Notes and failures</h2>\n<ul>\n";
    for (const std::string& n : p.notes) html += "<li>" + HtmlEscape(n) + "</li>\n";
    html += "</ul>\n";
  }
  html += p.after_notes_html + "</body></html>\n";
  const std::string path = out_dir + "/report/index.html";
  WriteTextFile(path, html);
  return path;
}

}  // namespace owlcal::reports
