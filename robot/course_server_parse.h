#pragma once
// How the course's two servo servers read one packet, field by field, so that the
// virtual Owl's `--server python` and `--server c` modes (robot/servo_server.h) behave as they do.
// Sources: the guide's Annex 2 (PFCsocket.py) and the course's MRSsocket.c (M R Simpson, 2017).
//
// Python server (Python 2):  packet = comm.recv(24); comm.send('ok'); if len(packet) < 24: quit;
//   A = map(int, packet.split(' ')); Rx, Ry, Lx, Ly, Neck = A[0..4]; clamp each to its limits.
//   split(' ') cuts at every single space (two spaces make an empty field); int() accepts
//   surrounding whitespace (space \t \n \r \v \f) and one sign, nothing else: a NUL, an empty
//   field or a letter raise ValueError, fewer than five fields IndexError. Either exception
//   kills the server (nothing catches it).
//
// C server (MRSsocket.c):  n = read(fd, buffer, 32); buffer[n] = '\0';
//   sscanf(buffer, "%d %d %d %d %d", &Rx, &Ry, &Lx, &Ly, &Neck) into GLOBALS that keep their
//   previous values (zero at start): fields are read in order until the first that is not a
//   number; the text ends at the first NUL; whitespace between fields may be any amount.
//   data = atoi(buffer) (the raw first field) is the reply ("%d\n\r") and the session control:
//   data < 0 ends the session, -2 also stops the server. Each global is then clamped in place.
//
// Values beyond +-99999999 saturate there (Python's int is unbounded, C's %d overflow is
// undefined; both end up clamped to the servo limits anyway).
#include <optional>
#include <string>
#include <string_view>

#include "models/robot_config.h"

namespace owlcal::robot {

struct PythonServerParse {
  std::optional<models::PwmVector> pwm_us;  // the five fields, before the clamp
  std::string exception;                    // when not: what Python would raise, e.g.
                                            // "ValueError: null byte in argument for int()"
};
PythonServerParse ParseLikePythonServer(std::string_view packet);

struct CServerScan {
  int num_fields = 0;  // what sscanf returns: fields assigned, 0..5 (EOF counts as 0)
  long long data = 0;  // atoi(buffer)
};
// Updates globals[0..num_fields) (wire order Rx Ry Lx Ly Neck) as sscanf would.
CServerScan ScanLikeCServer(std::string_view bytes, models::PwmVector* globals);

// Python's repr() of a byte string, for messages: '992\x00'.
std::string PythonRepr(std::string_view bytes);

}  // namespace owlcal::robot
