#pragma once
// Small CSV helpers shared by every file reader (observations, datasets, truth tables, logs).
// Cells are separated by ',' with no quoting (owlcal never writes a comma inside a cell);
// '\r' is dropped so files edited on Windows read the same.
#include <string>
#include <vector>

namespace owlcal::calib {

// Splits one line into cells; with trim, spaces around each cell are removed too.
std::vector<std::string> SplitCsvLine(const std::string& line, bool trim = false);

// cells[col] as a number. Throws std::runtime_error "WHERE: missing field FIELD" or
// "WHERE: field FIELD = 'x' is not a number"; WHERE is usually "path:line".
double CsvNumber(const std::vector<std::string>& cells, int col, const std::string& where, const std::string& field);

}  // namespace owlcal::calib
