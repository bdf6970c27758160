#pragma once
// Build provenance of the granflow executable (generated build_info.cpp): version and git
// commit (with "-dirty" when tracked files differed from it), build type, compiler, Trilinos.
#include <map>
#include <string>

std::map<std::string, std::string> granflow_build_info();
