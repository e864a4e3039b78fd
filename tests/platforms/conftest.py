"""The release builds of every platform (make dist), tested here: collected only by
`make test-platforms` (UNBOUND_PLATFORM_TESTS=1), which builds them first; `make test` skips them."""
import os

collect_ignore_glob = [] if os.environ.get("UNBOUND_PLATFORM_TESTS") else ["test_*.py"]
