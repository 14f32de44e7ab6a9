/* The one header bindgen reads (see build.rs).
 *
 * build.rs defines STRAHL_EMBREE_MAJOR (3 or 4) and puts the include directory of the
 * installed Embree on the search path, so the bindings always describe the library that is
 * linked: never a bundled copy of another release, whose struct sizes may differ
 * (Embree >= 4.3 grows RTCRayHit from 80 to 96 bytes). */
#if STRAHL_EMBREE_MAJOR == 4
#include <embree4/rtcore.h>
#elif STRAHL_EMBREE_MAJOR == 3
#include <embree3/rtcore.h>
#else
#error "STRAHL_EMBREE_MAJOR must be 3 or 4"
#endif
