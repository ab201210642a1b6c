// Empty on purpose: the translation unit that compiles a group of precompiled headers
// (cmake/precompiled_headers.cmake). Nothing links it.
