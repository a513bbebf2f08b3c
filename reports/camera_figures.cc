#include "reports/camera_figures.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "fitting/format.h"
#include "fitting/projection_uncertainty.h"
#include "models/statistics.h"
#include "reports/table.h"

namespace owlcal::reports {
namespace {

constexpr const char* kEyeColour[2] = {"#1f77b4", "#d62728"};

using models::Median;

// The views of each eye: d.views, else the per-view RMS the intrinsics fits recorded.
std::vector<ViewStat> Views(const ReportData& d) {
  if (!d.views.empty()) return d.views;
  std::vector<ViewStat> out;
  const nlohmann::json& diag = d.result.diagnostics;
  if (!diag.contains("intrinsics")) return out;
  for (int e = 0; e < 2; ++e) {
    const std::string eye = models::kEyeNames[e];
    if (!diag["intrinsics"].contains(eye) || !diag["intrinsics"][eye].contains("view_rms_px")) continue;
    const auto& j = diag["intrinsics"][eye];
    const auto rms = j["view_rms_px"];
    for (size_t i = 0; i < rms.size(); ++i) {
      ViewStat v;
      v.eye = e;
      v.frame = j.contains("frames") && i < j["frames"].size() ? j["frames"][i].get<int>() : int(i);
      v.name = "frame " + std::to_string(v.frame);
      v.rms_px = rms[i].is_null() ? NAN : rms[i].get<double>();
      out.push_back(v);
    }
  }
  return out;
}

double Threshold(const std::vector<ViewStat>& views, int eye) {
  std::vector<double> r;
  for (const auto& v : views)
    if (v.eye == eye && std::isfinite(v.rms_px)) r.push_back(v.rms_px);
  const double med = Median(r);
  std::vector<double> dev;
  for (double x : r) dev.push_back(std::abs(x - med));
  return std::max(med + 3 * 1.4826 * Median(dev), 1.5 * med);
}

std::optional<Figure> ViewRmsFigure(const ReportData& d) {
  const std::vector<ViewStat> views = Views(d);
  if (views.empty()) return std::nullopt;
  Figure f{"view_rms",
           "RMS reprojection error per calibration view",
           "view (in recording order)",
           "RMS error [px]",
           {},
           {"set yrange [0:*]", "set style fill solid 0.7 noborder", "set bmargin 6", "set xtics out nomirror"},
           "outside bottom center horizontal"};
  f.width_px = 1100;
  const auto worst = WorstViews(d, 4);
  int x0 = 0;
  for (int e = 0; e < 2; ++e) {
    Series bars{std::string(models::kEyeNames[e]) + " eye",
                std::string("boxes lc rgb '") + kEyeColour[e] + "'",
                "1:2",
                {"view", "rms_px"},
                {}};
    int n = 0;
    for (const auto& v : views)
      if (v.eye == e) bars.rows.push_back({double(x0 + n++), v.rms_px});
    if (bars.rows.empty()) continue;
    const double thr = Threshold(views, e);
    f.series.push_back(bars);
    f.series.push_back({e == 0 ? "retake threshold (median + 3 MAD)" : "",
                        "lines lw 2 dt 2 lc rgb '#333333'",
                        "1:2",
                        {"view", "threshold_px"},
                        {{x0 - 0.5, thr}, {x0 + n - 0.5, thr}}});
    // Number the worst views on the plot (rank 1 = worst); the caption names them.
    n = 0;
    for (const auto& v : views) {
      if (v.eye != e) continue;
      for (size_t k = 0; k < worst.size(); ++k)
        if (worst[k].view.eye == e && worst[k].view.frame == v.frame)
          f.settings.push_back("set label '" + std::to_string(k + 1) + "' at " + Fmt(x0 + n, 6) + "," +
                               Fmt(v.rms_px, 6) + " center offset 0,0.7 font ',12' front");
      ++n;
    }
    x0 += n + 3;
  }
  if (f.series.empty()) return std::nullopt;
  f.settings.push_back("set boxwidth 0.8");
  f.settings.push_back("set xrange [-1:" + std::to_string(std::max(1, x0 - 2)) + "]");
  f.settings.push_back("set offsets 0, 0, graph 0.1, 0");
  std::string names;
  for (size_t k = 0; k < worst.size(); ++k)
    names += (k ? ", " : "") + std::to_string(k + 1) + " = " + models::kEyeNames[worst[k].view.eye] + " eye, " +
             worst[k].view.name + " (" + Fmt(worst[k].view.rms_px, 3) + " px)";
  f.caption = "RMS reprojection error of each calibration view (left eye first, then the right). " +
              (worst.empty() ? std::string("No view stands out above its eye's threshold (median + 3 scaled MADs).")
                             : "Views above the threshold: " + names +
                                   ". Look at those images: a blurred, badly lit or partly occluded board, or a "
                                   "board that moved during the exposure; retake or drop them.");
  return f;
}

std::vector<Figure> ResidualFigures(const ReportData& d) {
  std::vector<Figure> out;
  for (int e = 0; e < 2; ++e) {
    std::vector<const ResidualPoint*> pts;
    for (const auto& r : d.residuals)
      if (r.eye == e) pts.push_back(&r);
    if (pts.empty()) continue;
    const std::string eye = models::kEyeNames[e];
    double sum2 = 0, maxr = 0;
    for (const auto* p : pts) {
      sum2 += p->dx * p->dx + p->dy * p->dy;
      maxr = std::max(maxr, std::hypot(p->dx, p->dy));
    }
    const double rms_axis = std::sqrt(sum2 / (2.0 * pts.size()));
    const int w = d.config.image_width, h = d.config.image_height;
    // Arrows scaled so that the 99th percentile residual is 25 px long on the image.
    std::vector<double> mags;
    for (const auto* p : pts) mags.push_back(std::hypot(p->dx, p->dy));
    std::sort(mags.begin(), mags.end());
    const double p99 = std::max(1e-9, mags[size_t(0.99 * (mags.size() - 1))]);
    const double scale = 25.0 / p99;
    Figure field{"residual_field_" + eye,
                 eye + " eye: reprojection residuals over the image (arrows \u00d7" + Fmt(scale, 3) + ")",
                 "x [px]",
                 "y [px]",
                 {},
                 {},
                 "off"};
    field.settings = {"unset grid",
                      "set size ratio -1",
                      "set xrange [0:" + std::to_string(w - 1) + "]",
                      "set yrange [" + std::to_string(h - 1) + ":0]",
                      "set cblabel '|residual| [px]'",
                      "set cbrange [0:" + Fmt(p99, 3) + "]",
                      kViridis};
    Series s{"",
             "vectors head size 4,20 filled lw 1.2 lc palette",
             "1:2:5:6:7",
             {"x_px", "y_px", "dx_px", "dy_px", "dx_plot", "dy_plot", "norm_px"},
             {}};
    for (const auto* p : pts)
      s.rows.push_back(
          {p->x, p->y, p->dx, p->dy, p->dx * scale, p->dy * scale, std::min(std::hypot(p->dx, p->dy), p99)});
    field.series.push_back(s);
    field.width_px = 900;
    field.height_px = 720;
    field.caption = "Every calibration corner of the " + eye +
                    " eye, with its residual (reprojected minus detected) "
                    "as an arrow " +
                    Fmt(scale, 3) +
                    " times its length; colour = |residual| (capped at the 99th "
                    "percentile, " +
                    Fmt(p99, 3) +
                    " px). Random directions mean the lens model fits; arrows that "
                    "align (radially at the edges, or all one way in a region) mean a model or detection error there.";
    out.push_back(field);

    // Histogram of the x and y components with the normal density of their RMS.
    const double lim = std::max(4 * rms_axis, 1e-6);
    const int bins = 40;
    const double bw = 2 * lim / bins;
    std::vector<double> cx(bins, 0), cy(bins, 0);
    int outside = 0;
    for (const auto* p : pts) {
      const int ix = int(std::floor((p->dx + lim) / bw)), iy = int(std::floor((p->dy + lim) / bw));
      if (ix >= 0 && ix < bins)
        ++cx[ix];
      else
        ++outside;
      if (iy >= 0 && iy < bins)
        ++cy[iy];
      else
        ++outside;
    }
    Figure hist{"residual_hist_" + eye,
                eye + " eye: distribution of the residuals",
                "residual [px]",
                "corners per bin",
                {},
                {"set style fill transparent solid 0.45 noborder", "set bmargin 6"},
                "outside bottom center horizontal"};
    Series hx{"x residuals", "boxes lc rgb '#1f77b4'", "1:2", {"residual_px", "count"}, {}};
    Series hy{"y residuals", "boxes lc rgb '#ff7f0e'", "1:2", {"residual_px", "count"}, {}};
    Series gauss{"normal, \u03c3 = RMS = " + Fmt(rms_axis, 3) + " px",
                 "lines lw 2.5 lc rgb 'black'",
                 "1:2",
                 {"residual_px", "count"},
                 {}};
    for (int i = 0; i < bins; ++i) {
      const double c = -lim + (i + 0.5) * bw;
      hx.rows.push_back({c, cx[i]});
      hy.rows.push_back({c, cy[i]});
    }
    for (int i = 0; i <= 200; ++i) {
      const double x = -lim + 2 * lim * i / 200.0;
      gauss.rows.push_back(
          {x, pts.size() * bw * std::exp(-0.5 * x * x / (rms_axis * rms_axis)) / (rms_axis * std::sqrt(2 * M_PI))});
    }
    hist.series = {hx, hy, gauss};
    hist.settings.push_back("set boxwidth " + Fmt(bw, 6));
    hist.settings.push_back("set xrange [" + Fmt(-lim, 4) + ":" + Fmt(lim, 4) + "]");
    hist.caption = std::to_string(pts.size()) + " corners of the " + eye + " eye, RMS per axis " + Fmt(rms_axis, 3) +
                   " px, largest |residual| " + Fmt(maxr, 3) + " px; " + std::to_string(outside) +
                   " components beyond \u00b14 RMS (outside the plot). A histogram that matches the curve means "
                   "Gaussian corner noise; heavy tails mean outliers.";
    out.push_back(hist);
  }
  return out;
}

std::vector<Figure> UncertaintyFigures(const ReportData& d) {
  std::vector<Figure> out;
  for (int e = 0; e < 2; ++e) {
    const models::CameraIntrinsics* cam =
        d.result.cameras[e] ? &*d.result.cameras[e] : (d.result.head ? &d.result.head->intrinsics[e] : nullptr);
    if (!cam) continue;
    std::string source;
    const Eigen::MatrixXd cov = fitting::IntrinsicsCovariance(d.result, e, &source);
    if (cov.size() == 0 || cov.norm() == 0) continue;
    const std::string eye = models::kEyeNames[e];
    std::vector<fitting::CornerResidual> res;
    double s2 = 0;
    for (const auto& r : d.residuals)
      if (r.eye == e) {
        res.push_back({r.x, r.y, r.dx, r.dy});
        s2 += r.dx * r.dx + r.dy * r.dy;
      }
    const double sigma = res.empty() ? NAN : std::sqrt(s2 / (2.0 * res.size()));
    const fitting::ValidIntrinsicsRegion v = fitting::ComputeValidIntrinsicsRegion(*cam, cov, res, sigma);
    const fitting::UncertaintyGrid& g = v.uncertainty;
    Figure f{"uncertainty_" + eye,
             eye + " eye: projection uncertainty at infinity (worst direction)",
             "x [px]",
             "y [px]",
             {},
             {},
             "outside bottom center horizontal"};
    // Colour scale up to the 95th percentile (the extreme corners would wash out the rest).
    std::vector<double> finite;
    for (double x : g.sigma_px)
      if (std::isfinite(x)) finite.push_back(x);
    std::sort(finite.begin(), finite.end());
    const double smax = finite.empty() ? 1.0 : finite[size_t(0.95 * (finite.size() - 1))];
    f.settings = {"set size ratio -1",
                  "set xrange [-0.5:" + std::to_string(cam->width) + "]",
                  "set yrange [" + std::to_string(cam->height) + ":-0.5]",
                  "set cblabel '\u03c3 [px]'",
                  kViridis,
                  "set cbrange [0:" + Fmt(std::max(smax, 1e-9), 3) + "]",
                  "set bmargin 6",
                  "unset grid"};
    Series img{"", "image", "1:2:3", {"x_px", "y_px", "sigma_px"}, {}};
    for (size_t k = 0; k < g.sigma_px.size(); ++k) img.rows.push_back({g.x_px[k], g.y_px[k], g.sigma_px[k]});
    f.series.push_back(img);
    if (!v.contour.empty()) {
      Series c{
          "valid-intrinsics region (mrcal's definition)", "lines lw 3 lc rgb '#ff7f0e'", "1:2", {"x_px", "y_px"}, {}};
      for (const auto& p : v.contour) c.rows.push_back({p.x(), p.y()});
      f.series.push_back(c);
    }
    // The set verdict's trusted region (evaluation/set_verdict.h), when the result has one: the
    // region the verdict judged, marked on the same image.
    std::string verdict_text;
    const nlohmann::json& sv = d.result.verdict;
    if (sv.is_object() && sv.contains("metrics") && sv.at("metrics").contains("eyes") &&
        sv.at("metrics").at("eyes").contains(eye) && sv.at("metrics").at("eyes").at(eye).contains("trusted_region") &&
        sv.at("metrics").at("eyes").at(eye).at("trusted_region").contains("sigma_px")) {
      const auto& tr = sv.at("metrics").at("eyes").at(eye).at("trusted_region");
      const auto xs = tr.at("x_px").get<std::vector<double>>(), ys = tr.at("y_px").get<std::vector<double>>();
      const auto sg = tr.at("sigma_px").get<std::vector<double>>();
      const double limit = tr.value("limit_px", 0.0), range = tr.value("range_m", 0.0);
      Series t{"trusted by the set verdict", "points pt 7 ps 0.8 lc rgb '#ffffff'", "1:2", {"x_px", "y_px"}, {}};
      for (size_t k = 0; k < xs.size() && k < ys.size() && k < sg.size(); ++k)
        if (sg[k] >= 0 && sg[k] < limit) t.rows.push_back({xs[k], ys[k]});
      if (!t.rows.empty()) f.series.push_back(t);
      verdict_text =
          " White dots: the set verdict's trusted region, the figure the verdict judges (its own map, board "
          "poses in the state, " +
          (range > 0 ? "at " + fitting::FixedOrDash(range, 2) + " m" : std::string("at infinity")) + ": \u03c3 < " +
          fitting::FixedOrDash(tr.value("threshold_noise", 0.0), 1) + " \u00d7 the corner noise " +
          fitting::FixedOrDash(tr.value("noise_px", 0.0), 3) + " px = " + fitting::FixedOrDash(limit, 2) +
          " px): " + fitting::FixedOrDash(100 * tr.value("working_fraction", 0.0), 0) + " % of the working region, " +
          fitting::FixedOrDash(100 * tr.value("fraction", 0.0), 0) +
          " % of the image. mrcal's own default (1 \u00d7 noise) is "
          "stricter and is what the exported .cameramodel carries.";
    }
    f.width_px = 900;
    f.height_px = 760;
    f.caption =
        "How far a point at infinity may land from where the " + eye +
        " model projects it (1\u03c3, worst "
        "direction; the colour scale stops at the 95th percentile, " +
        Fmt(smax, 3) +
        " px), from the intrinsics "
        "covariance (" +
        source +
        "), a common camera rotation removed (it "
        "is absorbed by the extrinsics, as in mrcal). Orange: mrcal's valid-intrinsics region (uncertainty "
        "< 1 \u00d7 the corner noise " +
        Fmt(sigma, 3) +
        " px, |mean residual| < 0.5 px, stdev < 1.5 \u00d7 "
        "noise, > 3 residuals per cell): " +
        Fmt(100 * v.valid_fraction, 3) + " % of the image." +
        (verdict_text.empty() ? std::string(" Outside it, add views whose board reaches there.") : verdict_text);
    out.push_back(f);
  }
  return out;
}

std::optional<Figure> PoseFigure(const ReportData& d) {
  if (d.boards.empty()) return std::nullopt;
  // Plot axes: x right, z forward (depth), -y up (camera frame: y down).
  auto P = [](const Eigen::Vector3d& p) { return std::vector<double>{p.x(), p.z(), -p.y()}; };
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  if (d.result.stereo) {
    const models::Rigid3d left_from_right = d.result.stereo->right_from_left.Inverse();
    R = left_from_right.rotation.toRotationMatrix();
    t = left_from_right.translation;
  }
  Figure f{"poses_3d",
           "Cameras and calibration board poses",
           "x [m]",
           "depth z [m]",
           {},
           {},
           "outside bottom center horizontal"};
  double depth = 0;
  for (const auto& b : d.boards)
    for (const auto& c : b.corners_in_cam) depth = std::max(depth, c.z());
  const double fs = std::max(0.02, 0.08 * depth);  // frustum size
  for (int e = 0; e < 2; ++e) {
    Series boards{std::string("boards seen by the ") + models::kEyeNames[e] + " eye",
                  std::string("vectors nohead lw 1.2 lc rgb '") + kEyeColour[e] + "'",
                  "1:2:3:4:5:6",
                  {"x_m", "z_m", "up_m", "dx_m", "dz_m", "dup_m"},
                  {}};
    for (const auto& b : d.boards) {
      if (b.eye != e) continue;
      for (int k = 0; k < 4; ++k) {
        const Eigen::Vector3d a = e ? Eigen::Vector3d(R * b.corners_in_cam[k] + t) : b.corners_in_cam[k];
        const Eigen::Vector3d c =
            e ? Eigen::Vector3d(R * b.corners_in_cam[(k + 1) % 4] + t) : b.corners_in_cam[(k + 1) % 4];
        const auto pa = P(a), pc = P(c);
        boards.rows.push_back({pa[0], pa[1], pa[2], pc[0] - pa[0], pc[1] - pa[1], pc[2] - pa[2]});
      }
    }
    if (!boards.rows.empty()) f.series.push_back(boards);
    // The camera: a pyramid from its centre to an image-shaped rectangle at depth fs.
    Series cam{std::string(models::kEyeNames[e]) + " camera",
               "vectors nohead lw 2.5 lc rgb 'black'",
               "1:2:3:4:5:6",
               {"x_m", "z_m", "up_m", "dx_m", "dz_m", "dup_m"},
               {}};
    const double a = 0.5 * fs, b = 0.375 * fs;
    const Eigen::Vector3d corners[4] = {{-a, -b, fs}, {a, -b, fs}, {a, b, fs}, {-a, b, fs}};
    auto W = [&](const Eigen::Vector3d& p) { return e ? Eigen::Vector3d(R * p + t) : p; };
    for (int k = 0; k < 4; ++k) {
      const auto o = P(W(Eigen::Vector3d::Zero())), c0 = P(W(corners[k])), c1 = P(W(corners[(k + 1) % 4]));
      cam.rows.push_back({o[0], o[1], o[2], c0[0] - o[0], c0[1] - o[1], c0[2] - o[2]});
      cam.rows.push_back({c0[0], c0[1], c0[2], c1[0] - c0[0], c1[1] - c0[1], c1[2] - c0[2]});
    }
    if (e == 0 || d.result.stereo) {
      // Both pyramids are black: one legend entry names them both.
      if (e == 0 && d.result.stereo) cam.title = "left and right cameras";
      if (e == 1) cam.title = "";
      f.series.push_back(cam);
    }
  }
  f.splot = true;
  f.key = "top left";
  f.settings = {"set zlabel 'up [m]' rotate parallel",
                "set view 62, 28, 1.25, 1.2",
                "set view equal xyz",
                "set xyplane at " + Fmt(-depth * 0.3, 3),
                "set xtics 0.1",
                "set ytics 0.2",
                "set ztics 0.1"};
  f.width_px = 1000;
  f.height_px = 760;
  f.caption =
      "The left camera at the origin, the right camera at its calibrated pose, and every board pose of the "
      "calibration (the outline of its corner grid) relative to the camera that saw it. Good data has boards "
      "at several distances and tilted in different directions, filling each camera's view.";
  return f;
}

}  // namespace

std::vector<WorstView> WorstViews(const ReportData& d, size_t max_count) {
  const std::vector<ViewStat> views = Views(d);
  std::vector<WorstView> out;
  for (int e = 0; e < 2; ++e) {
    const double thr = Threshold(views, e);
    for (const auto& v : views)
      if (v.eye == e && std::isfinite(v.rms_px) && v.rms_px > thr) out.push_back({v, thr});
  }
  std::sort(out.begin(), out.end(), [](const WorstView& a, const WorstView& b) {
    return a.view.rms_px / a.threshold_px > b.view.rms_px / b.threshold_px;
  });
  if (out.size() > max_count) out.resize(max_count);
  return out;
}

std::vector<Figure> MakeCameraFigures(const ReportData& d) {
  std::vector<Figure> out;
  if (auto f = ViewRmsFigure(d)) out.push_back(*f);
  for (auto& f : ResidualFigures(d)) out.push_back(f);
  for (auto& f : UncertaintyFigures(d)) out.push_back(f);
  if (auto f = PoseFigure(d)) out.push_back(*f);
  return out;
}

}  // namespace owlcal::reports
