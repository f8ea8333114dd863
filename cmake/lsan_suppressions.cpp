// Sanitizer builds only (HAZMAP_SANITIZE): leaks LeakSanitizer reports in system libraries that
// keep process-lifetime caches on purpose, not in hazmap. Linked into the CLI and each test
// executable; LeakSanitizer reads this hook at start-up (no LSAN_OPTIONS needed).
//   libfontconfig: its configuration and font cache, loaded once by Cairo's text (figures) and
//   never freed (1,016 bytes in 12 blocks, AsyncBackEnd.TrackingNeverWaits…, 2026-12-04).
extern "C" const char* __lsan_default_suppressions() {
  return "leak:libfontconfig.so\n";
}
