// tinyobjloader's implementation, compiled with the harnesses' sanitizers and coverage.
#define TINYOBJLOADER_IMPLEMENTATION
#include <tiny_obj_loader.h>
