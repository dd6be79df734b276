// Keeps lcv_test_support non-empty before the first helper lands.
namespace lcv::test_internal { int kSupportAnchor = 0; }
