"""env-server's `/ws/batch` sessions in this process (see src/lib.rs)."""

class Batch:
    """The sessions of one `/ws/batch` connection, held in this process."""

    def __init__(self) -> None: ...
    def message(self, text: str) -> str | None:
        """One `/ws/batch` message (JSON text) and its answer; None once closed."""

def metadata() -> str:
    """`GET /metadata`'s document (JSON text)."""
