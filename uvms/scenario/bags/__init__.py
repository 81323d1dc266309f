"""ROS 2 bags: a run written as a bag (``writer``) with its TF tree (``tf_tree``), and a bag read back as a log for the
identification (``reader``, within ``limits``; the thrusts of a log as a body wrench, ``thrust_log``). They sit under
``scenario`` because they write and read a scenario's results (:class:`uvms.sim.result.SimulationResult` of a run,
its model) and the identification's log (:mod:`uvms.dynamics.identification.data`)."""
