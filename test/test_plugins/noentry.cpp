// A shared library that is not a saccade plugin: it exports no entry.
extern "C" int saccade_noentry_something() { return 42; }
