"""``nlos fit``: a user's room (scan or scene) in, a trained room model out (``run.fit_room``)."""
