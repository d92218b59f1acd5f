#pragma once
namespace gvd::low {
inline int low() { return 1; }
}  // namespace gvd::low
