"""The adversarial efficacy campaign's generator: families of fence shapes, sites, winds, pilots and
platforms drawn by seed into ordinary scenario files, each case once per geofence variant (predictive,
reactive, unprotected). Built on the scenario definition (:mod:`scenarios.definition`); flown by ``batch``
and reported by :mod:`analysis.campaign_report`.
"""
