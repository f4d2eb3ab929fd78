"""Planning and estimation: MPPI, the UKF and its window estimator, the controller's loop body
(:mod:`dexpush.control.policy`) and :class:`dexpush.control.controller.PushingController`."""
