#include "fitting/fix_list.h"

#include <algorithm>
#include <sstream>

namespace owlcal::fitting {

bool ApplyFixList(const std::string& list, IntrinsicsFitOptions* o, std::string* why) {
  if (list.empty()) return true;
  std::stringstream in(list);
  std::string item;
  while (std::getline(in, item, ',')) {
    item.erase(0, item.find_first_not_of(' '));
    item.erase(item.find_last_not_of(' ') + 1);
    if (item.size() == 2 && item[0] == 'k' && item[1] >= '1' && item[1] <= '6') {
      const int k = item[1] - '0';
      if (k == 3)
        o->fix_k3 = true;
      else if (std::find(o->fix_radial.begin(), o->fix_radial.end(), k) == o->fix_radial.end())
        o->fix_radial.push_back(k);
    } else if (item == "principal_point") {
      o->fix_principal_point = true;
    } else if (item == "aspect_ratio" || item == "fx=fy") {
      o->fix_aspect_ratio = true;
    } else if (item == "tangential") {
      o->fix_tangential = true;
    } else {
      if (why)
        *why = "--fix: unknown item '" + item + "' in '" + list +
               "': use k1 ... k6, principal_point, aspect_ratio (or fx=fy) and tangential, comma-separated";
      return false;
    }
  }
  std::sort(o->fix_radial.begin(), o->fix_radial.end());
  return true;
}

std::vector<std::string> FixListOf(const IntrinsicsFitOptions& o) {
  std::vector<std::string> out;
  for (int k = 1; k <= 6; ++k)
    if ((k == 3 && o.fix_k3) || std::find(o.fix_radial.begin(), o.fix_radial.end(), k) != o.fix_radial.end())
      out.push_back(std::string(1, 'k').append(std::to_string(k)));  // GCC 12 -Wrestrict on "k" + s
  if (o.fix_principal_point) out.push_back("principal_point");
  if (o.fix_aspect_ratio) out.push_back("aspect_ratio");
  if (o.fix_tangential) out.push_back("tangential");
  return out;
}

}  // namespace owlcal::fitting
